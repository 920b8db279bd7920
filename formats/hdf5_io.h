#pragma once
/// Thin RAII layer over the HDF5 C API for the bundle reader and writer. Internal to
/// formats/: nothing outside this folder includes HDF5.
///
/// Determinism: every group and dataset is created with object time tracking off, so
/// the same content gives the same bytes.

#include <hdf5.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace fissure::formats::h5 {

/// Owns one hid_t and closes it with the matching H5?close.
class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, herr_t (*close)(hid_t)) : m_id(id), m_close(close) {}
  ~Handle() { reset(); }
  Handle(Handle&& other) noexcept : m_id(other.m_id), m_close(other.m_close) { other.m_id = H5I_INVALID_HID; }
  Handle& operator=(Handle&& other) noexcept {
    if (this != &other) {
      reset();
      m_id = other.m_id;
      m_close = other.m_close;
      other.m_id = H5I_INVALID_HID;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;

  [[nodiscard]] hid_t id() const { return m_id; }
  [[nodiscard]] bool valid() const { return m_id >= 0; }
  void reset() {
    if (m_id >= 0 && m_close) m_close(m_id);
    m_id = H5I_INVALID_HID;
  }

 private:
  hid_t m_id = H5I_INVALID_HID;
  herr_t (*m_close)(hid_t) = nullptr;
};

/// Silences HDF5's own error stack printing; we report errors ourselves.
void silence_library_errors();

/// Creates `path`: `write` fills an HDF5 file built in memory (1.8 file format, whose
/// metadata is checksummed), which is then written through a temporary beside `path`
/// and renamed over it (common/output_file.h): a reader never sees a half-written file,
/// and a failure, a signal or a full disk leaves no file behind. Errors name the path.
void write_file_atomically(const std::filesystem::path& path, const std::function<void(hid_t file)>& write);
Handle open_file_read_only(const std::string& path);
/// True when the file starts with an HDF5 superblock of version 2 or later, the
/// container whose metadata HDF5 checksums (what Fissure writes since schema 1.1).
/// False for the legacy container (superblock 0 or 1, no checksums), on which HDF5
/// 1.10 can read out of bounds or crash when bytes are damaged, and for anything else.
bool has_checksummed_metadata(const std::filesystem::path& path);
/// For a file without checksummed metadata, runs `read_all` (which should read
/// everything the caller will) in a child process first, and throws fissure::Error
/// naming `path` if HDF5 crashed there. Costs one fork and one extra read, for legacy
/// files only.
void require_legacy_file_readable(const std::filesystem::path& path, const std::function<void()>& read_all);
Handle create_group(hid_t parent, const std::string& name);
Handle open_group(hid_t parent, const std::string& name);
bool has_link(hid_t parent, const std::string& name);

enum class ElementType { F64, U32, U8, U64, I32 };

/// Writes a row-major dataset with the given shape. Datasets of more than a few
/// thousand elements are chunked and deflate-compressed (with byte shuffle).
void write_dataset(hid_t parent, const std::string& name, ElementType type, const std::vector<hsize_t>& shape,
                   const void* data);

/// Shape of a dataset, or nullopt if it does not exist. Throws fissure::Error when the
/// shape claims more data than the file can hold (require_backed_by_file), so callers
/// may allocate what it says.
std::optional<std::vector<hsize_t>> dataset_shape(hid_t parent, const std::string& name);
/// Throws fissure::Error when `shape` of `dataset` needs more bytes than its storage in
/// the file could expand to: a corrupted dimension must fail before an allocation.
void require_backed_by_file(hid_t dataset, const std::string& name, const std::vector<hsize_t>& shape);
/// Reads a whole dataset, converting to `type` in memory. `data` must hold the product of its shape.
void read_dataset(hid_t parent, const std::string& name, ElementType type, void* data);
/// Bytes the dataset occupies in the file (after compression).
std::uint64_t dataset_storage_bytes(hid_t parent, const std::string& name);

void write_attribute(hid_t object, const std::string& name, const std::string& value);
void write_attribute(hid_t object, const std::string& name, std::int64_t value);
void write_attribute(hid_t object, const std::string& name, double value);
std::optional<double> read_double_attribute(hid_t object, const std::string& name);
std::optional<std::string> read_string_attribute(hid_t object, const std::string& name);
std::optional<std::int64_t> read_integer_attribute(hid_t object, const std::string& name);

/// Names of the links (groups, datasets) in a group, in name order.
std::vector<std::string> list_links(hid_t group);

}  // namespace fissure::formats::h5
