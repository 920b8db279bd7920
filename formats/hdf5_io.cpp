#include "formats/hdf5_io.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string_view>
#include <system_error>
#include <numeric>

#include "common/child_probe.h"
#include "common/error.h"
#include "common/input_file.h"
#include "common/output_file.h"

namespace fissure::formats::h5 {
namespace {

hid_t memory_type(ElementType type) {
  switch (type) {
    case ElementType::F64: return H5T_NATIVE_DOUBLE;
    case ElementType::U32: return H5T_NATIVE_UINT32;
    case ElementType::U8: return H5T_NATIVE_UINT8;
    case ElementType::U64: return H5T_NATIVE_UINT64;
    case ElementType::I32: return H5T_NATIVE_INT32;
  }
  return H5T_NATIVE_UINT8;
}

/// Little-endian file types, so a bundle is the same bytes on every machine.
hid_t file_type(ElementType type) {
  switch (type) {
    case ElementType::F64: return H5T_IEEE_F64LE;
    case ElementType::U32: return H5T_STD_U32LE;
    case ElementType::U8: return H5T_STD_U8LE;
    case ElementType::U64: return H5T_STD_U64LE;
    case ElementType::I32: return H5T_STD_I32LE;
  }
  return H5T_STD_U8LE;
}

void check(herr_t status, const std::string& what) {
  if (status < 0) throw Error("HDF5: " + what + " failed");
}

Handle no_time_tracking(hid_t property_class) {
  Handle plist(H5Pcreate(property_class), H5Pclose);
  check(H5Pset_obj_track_times(plist.id(), false), "disabling object timestamps");
  return plist;
}

constexpr hsize_t kChunkThreshold = 4096;  // elements; smaller datasets stay contiguous
constexpr hsize_t kChunkBytes = 1 << 20;   // about 1 MiB per chunk
// Deflate cannot expand data by more than 1032:1; shuffle and checksums add nothing.
// A dataset whose shape claims more than this from its stored bytes is corrupt, and
// is refused before anything is allocated for it.
constexpr long double kMaxExpansion = 1040.0L;
constexpr std::size_t kMemoryFileIncrement = 4 << 20;  // the in-memory file grows 4 MiB at a time

/// Bob Jenkins' lookup3 hash (hashlittle), the checksum HDF5 puts on its metadata.
std::uint32_t lookup3(const unsigned char* bytes, std::size_t length, std::uint32_t initial) {
  const auto rotate = [](std::uint32_t x, int k) { return (x << k) | (x >> (32 - k)); };
  const auto word = [](const unsigned char* p) {
    return std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 | std::uint32_t{p[3]} << 24;
  };
  std::uint32_t a = 0xdeadbeefu + static_cast<std::uint32_t>(length) + initial, b = a, c = a;
  for (; length > 12; length -= 12, bytes += 12) {
    a += word(bytes), b += word(bytes + 4), c += word(bytes + 8);
    a -= c, a ^= rotate(c, 4), c += b, b -= a, b ^= rotate(a, 6), a += c;
    c -= b, c ^= rotate(b, 8), b += a, a -= c, a ^= rotate(c, 16), c += b;
    b -= a, b ^= rotate(a, 19), a += c, c -= b, c ^= rotate(b, 4), b += a;
  }
  if (length == 0) return c;
  unsigned char tail[12] = {};
  std::copy(bytes, bytes + length, tail);
  a += word(tail), b += word(tail + 4), c += word(tail + 8);
  c ^= b, c -= rotate(b, 14), a ^= c, a -= rotate(c, 11), b ^= a, b -= rotate(a, 25);
  c ^= b, c -= rotate(b, 16), a ^= c, a -= rotate(c, 4), b ^= a, b -= rotate(a, 14);
  c ^= b, c -= rotate(b, 24);
  return c;
}

/// HDF5 1.10's H5Fget_file_image clears the superblock's "open for writing" flags in
/// the image but keeps the checksum of the flags set, so the image would not open.
/// Recomputes the checksum of a version-2 superblock at offset 0 (what we write).
void repair_superblock_checksum(std::vector<char>& image) {
  constexpr std::size_t kChecked = 44;  // signature … root object header address (8-byte offsets)
  static constexpr char kSignature[] = "\x89HDF\r\n\x1a\n";
  if (image.size() < kChecked + 4 || !std::equal(kSignature, kSignature + 8, image.begin()) || image[8] != 2 ||
      image[9] != 8) {
    throw Error("HDF5: unexpected superblock in the file image", "this is a bug; please report it");
  }
  const std::uint32_t sum = lookup3(reinterpret_cast<const unsigned char*>(image.data()), kChecked, 0);
  for (int k = 0; k < 4; ++k) image[kChecked + k] = static_cast<char>((sum >> (8 * k)) & 0xff);
}

}  // namespace

void silence_library_errors() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

void write_file_atomically(const std::filesystem::path& path, const std::function<void(hid_t file)>& write) {
  silence_library_errors();
  // Built in memory, then written with plain POSIX I/O: HDF5 never touches the disk, so
  // a full disk is one clean write error (HDF5 1.10 segfaults at exit when a file it
  // failed to flush is still open), and a reader never sees a half-written file.
  const Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  check(H5Pset_fapl_core(fapl.id(), kMemoryFileIncrement, false), "in-memory file driver");
  // The 1.8 file format checksums every object header and the superblock, so a
  // corrupted byte in a bundle's metadata is detected before it is parsed.
  check(H5Pset_libver_bounds(fapl.id(), H5F_LIBVER_V18, H5F_LIBVER_V18), "file format version");
  const Handle fcpl = no_time_tracking(H5P_FILE_CREATE);
  std::vector<char> image;
  {
    const Handle file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, fcpl.id(), fapl.id()), H5Fclose);
    if (!file.valid()) throw Error(path.string() + ": cannot create the HDF5 file in memory");
    try {
      write(file.id());
    } catch (const Error& e) {
      throw Error(path.string() + ": " + e.what(), e.hint());
    }
    check(H5Fflush(file.id(), H5F_SCOPE_GLOBAL), "flushing " + path.string());
    const ssize_t size = H5Fget_file_image(file.id(), nullptr, 0);
    if (size < 0) throw Error("HDF5: cannot size the file image of " + path.string());
    image.resize(static_cast<std::size_t>(size));
    if (H5Fget_file_image(file.id(), image.data(), image.size()) != size) {
      throw Error("HDF5: cannot copy the file image of " + path.string());
    }
  }
  repair_superblock_checksum(image);
  fissure::write_file_atomically(path, std::string_view(image.data(), image.size()));
}

Handle open_file_read_only(const std::string& path) {
  fissure::require_regular_input(path);  // HDF5 would read a FIFO or /dev/zero without end
  silence_library_errors();
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    throw Error(path + ": not an HDF5 file (or unreadable)", "check the path: bundles and trajectories are HDF5 files");
  }
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.valid()) throw Error(path + ": cannot open the HDF5 file");
  return file;
}

bool has_checksummed_metadata(const std::filesystem::path& path) {
  constexpr std::string_view kSignature("\x89HDF\r\n\x1a\n", 8);
  constexpr std::size_t kVersionOffset = kSignature.size();
  std::ifstream in(path, std::ios::binary);
  char head[kVersionOffset + 1] = {};
  if (!in.read(head, sizeof head)) return false;
  return std::string_view(head, kSignature.size()) == kSignature && static_cast<unsigned char>(head[kVersionOffset]) >= 2;
}

void require_legacy_file_readable(const std::filesystem::path& path, const std::function<void()>& read_all) {
  fissure::require_regular_input(path);
  if (inside_child_probe() || has_checksummed_metadata(path)) return;
  // A budget, as for assimp (issue 46): reading a sound legacy bundle takes well under
  // a second per 100 MiB, so a damaged one that loops or allocates without end stops.
  std::error_code ec;
  const double mib = static_cast<double>(std::filesystem::file_size(path, ec) >> 20);
  ChildProbeLimits limits;
  limits.wall_seconds = 10.0 + mib / 10.0;
  limits.cpu_seconds = limits.wall_seconds + 2.0;
  limits.memory_bytes = (std::uint64_t{2} << 30) + 16 * (std::uint64_t{1} << 20) * static_cast<std::uint64_t>(mib);
  const ChildProbeOutcome outcome = run_in_child(read_all, limits);
  if (outcome.finished) return;
  throw Error(path.string() + ": damaged HDF5 file: reading it " + outcome.how + " inside the HDF5 library",
              "this file uses HDF5's legacy container, which has no checksums; a file written by this version "
              "(re-bake the bundle, or record the run again) detects damage as a clean error");
}

Handle create_group(hid_t parent, const std::string& name) {
  const Handle gcpl = no_time_tracking(H5P_GROUP_CREATE);
  Handle group(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, gcpl.id(), H5P_DEFAULT), H5Gclose);
  if (!group.valid()) throw Error("HDF5: cannot create group " + name);
  return group;
}

Handle open_group(hid_t parent, const std::string& name) {
  Handle group(H5Gopen2(parent, name.c_str(), H5P_DEFAULT), H5Gclose);
  if (!group.valid()) throw Error("HDF5: cannot open group " + name);
  return group;
}

bool has_link(hid_t parent, const std::string& name) { return H5Lexists(parent, name.c_str(), H5P_DEFAULT) > 0; }

void write_dataset(hid_t parent, const std::string& name, ElementType type, const std::vector<hsize_t>& shape,
                   const void* data) {
  Handle space(H5Screate_simple(static_cast<int>(shape.size()), shape.data(), nullptr), H5Sclose);
  if (!space.valid()) throw Error("HDF5: cannot create the dataspace of " + name);
  Handle dcpl = no_time_tracking(H5P_DATASET_CREATE);
  const hsize_t elements = std::accumulate(shape.begin(), shape.end(), hsize_t{1}, std::multiplies<>());
  if (elements >= kChunkThreshold) {
    std::vector<hsize_t> chunk = shape;
    const hsize_t row_elements = elements / std::max<hsize_t>(shape[0], 1);
    const hsize_t element_bytes = H5Tget_size(file_type(type));
    chunk[0] = std::clamp<hsize_t>(kChunkBytes / (row_elements * element_bytes), 1, shape[0]);
    check(H5Pset_chunk(dcpl.id(), static_cast<int>(chunk.size()), chunk.data()), "chunking " + name);
    check(H5Pset_shuffle(dcpl.id()), "shuffle filter on " + name);
    // Level 1: on the bunny-full bundle, 22% faster to write than level 4 for a file
    // 1.5% larger (doubles compress poorly past the shuffle filter).
    check(H5Pset_deflate(dcpl.id(), 1), "deflate filter on " + name);
  }
  Handle dataset(H5Dcreate2(parent, name.c_str(), file_type(type), space.id(), H5P_DEFAULT, dcpl.id(), H5P_DEFAULT),
                 H5Dclose);
  if (!dataset.valid()) throw Error("HDF5: cannot create dataset " + name);
  if (elements > 0) {
    check(H5Dwrite(dataset.id(), memory_type(type), H5S_ALL, H5S_ALL, H5P_DEFAULT, data), "writing " + name);
  }
}

std::optional<std::vector<hsize_t>> dataset_shape(hid_t parent, const std::string& name) {
  if (!has_link(parent, name)) return std::nullopt;
  Handle dataset(H5Dopen2(parent, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!dataset.valid()) return std::nullopt;
  Handle space(H5Dget_space(dataset.id()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.id());
  if (rank < 0 || rank > H5S_MAX_RANK) return std::nullopt;
  std::vector<hsize_t> shape(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(space.id(), shape.data(), nullptr);
  require_backed_by_file(dataset.id(), name, shape);
  return shape;
}

void require_backed_by_file(hid_t dataset, const std::string& name, const std::vector<hsize_t>& shape) {
  const Handle type(H5Dget_type(dataset), H5Tclose);
  const std::size_t element_bytes = type.valid() ? H5Tget_size(type.id()) : 0;
  if (element_bytes == 0) throw Error("HDF5: dataset " + name + " has no valid element type");
  // Bytes the file holds for it: what is allocated, and never more than the file.
  const Handle file(H5Iget_file_id(dataset), H5Fclose);
  hsize_t file_bytes = 0;
  if (!file.valid() || H5Fget_filesize(file.id(), &file_bytes) < 0) file_bytes = 0;
  const hsize_t stored = std::min<hsize_t>(H5Dget_storage_size(dataset), file_bytes);
  const Handle dcpl(H5Dget_create_plist(dataset), H5Pclose);
  const bool filtered = dcpl.valid() && H5Pget_nfilters(dcpl.id()) > 0;
  const long double backed = static_cast<long double>(stored) * (filtered ? kMaxExpansion : 1.0L);
  long double claimed = static_cast<long double>(element_bytes);
  for (const hsize_t extent : shape) claimed *= static_cast<long double>(extent);
  if (claimed > backed) {
    std::string dims;
    for (const hsize_t extent : shape) dims += (dims.empty() ? "" : ",") + std::to_string(extent);
    char bytes[32];
    std::snprintf(bytes, sizeof bytes, "%.3g", static_cast<double>(claimed));
    throw Error("HDF5: dataset " + name + " claims shape [" + dims + "] (" + bytes + " bytes) but the file holds only " +
                    std::to_string(stored) + " bytes of it",
                "the file is corrupt or truncated; re-create it");
  }
}

void read_dataset(hid_t parent, const std::string& name, ElementType type, void* data) {
  Handle dataset(H5Dopen2(parent, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!dataset.valid()) throw Error("HDF5: cannot open dataset " + name);
  Handle space(H5Dget_space(dataset.id()), H5Sclose);
  if (H5Sget_simple_extent_npoints(space.id()) == 0) return;
  check(H5Dread(dataset.id(), memory_type(type), H5S_ALL, H5S_ALL, H5P_DEFAULT, data), "reading " + name);
}

std::uint64_t dataset_storage_bytes(hid_t parent, const std::string& name) {
  Handle dataset(H5Dopen2(parent, name.c_str(), H5P_DEFAULT), H5Dclose);
  return dataset.valid() ? H5Dget_storage_size(dataset.id()) : 0;
}

void write_attribute(hid_t object, const std::string& name, const std::string& value) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  check(H5Tset_size(type.id(), std::max<std::size_t>(value.size(), 1)), "string attribute size");
  check(H5Tset_cset(type.id(), H5T_CSET_UTF8), "string attribute charset");
  check(H5Tset_strpad(type.id(), H5T_STR_NULLPAD), "string attribute padding");
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attribute(H5Acreate2(object, name.c_str(), type.id(), space.id(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attribute.valid()) throw Error("HDF5: cannot create attribute " + name);
  std::string padded = value;
  if (padded.empty()) padded.push_back('\0');
  check(H5Awrite(attribute.id(), type.id(), padded.data()), "writing attribute " + name);
}

void write_attribute(hid_t object, const std::string& name, std::int64_t value) {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attribute(H5Acreate2(object, name.c_str(), H5T_STD_I64LE, space.id(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attribute.valid()) throw Error("HDF5: cannot create attribute " + name);
  check(H5Awrite(attribute.id(), H5T_NATIVE_INT64, &value), "writing attribute " + name);
}

void write_attribute(hid_t object, const std::string& name, double value) {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attribute(H5Acreate2(object, name.c_str(), H5T_IEEE_F64LE, space.id(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attribute.valid()) throw Error("HDF5: cannot create attribute " + name);
  check(H5Awrite(attribute.id(), H5T_NATIVE_DOUBLE, &value), "writing attribute " + name);
}

std::optional<double> read_double_attribute(hid_t object, const std::string& name) {
  if (H5Aexists(object, name.c_str()) <= 0) return std::nullopt;
  Handle attribute(H5Aopen(object, name.c_str(), H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attribute.id()), H5Tclose);
  const H5T_class_t type_class = H5Tget_class(type.id());
  if (type_class != H5T_FLOAT && type_class != H5T_INTEGER) return std::nullopt;
  double value = 0.0;
  if (H5Aread(attribute.id(), H5T_NATIVE_DOUBLE, &value) < 0) return std::nullopt;
  return value;
}

std::optional<std::string> read_string_attribute(hid_t object, const std::string& name) {
  if (H5Aexists(object, name.c_str()) <= 0) return std::nullopt;
  Handle attribute(H5Aopen(object, name.c_str(), H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attribute.id()), H5Tclose);
  if (H5Tget_class(type.id()) != H5T_STRING) return std::nullopt;
  if (H5Tis_variable_str(type.id()) > 0) {
    // Variable-length strings, as h5py writes them by default.
    char* text = nullptr;
    Handle memtype(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(memtype.id(), H5T_VARIABLE);
    if (H5Aread(attribute.id(), memtype.id(), &text) < 0 || text == nullptr) return std::nullopt;
    std::string value(text);
    H5free_memory(text);
    return value;
  }
  const std::size_t size = H5Tget_size(type.id());
  std::string value(size, '\0');
  if (H5Aread(attribute.id(), type.id(), value.data()) < 0) return std::nullopt;
  value.resize(value.find('\0') == std::string::npos ? size : value.find('\0'));
  return value;
}

std::optional<std::int64_t> read_integer_attribute(hid_t object, const std::string& name) {
  if (H5Aexists(object, name.c_str()) <= 0) return std::nullopt;
  Handle attribute(H5Aopen(object, name.c_str(), H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attribute.id()), H5Tclose);
  if (H5Tget_class(type.id()) != H5T_INTEGER) return std::nullopt;
  std::int64_t value = 0;
  if (H5Aread(attribute.id(), H5T_NATIVE_INT64, &value) < 0) return std::nullopt;
  return value;
}

std::vector<std::string> list_links(hid_t group) {
  std::vector<std::string> names;
  auto collect = [](hid_t, const char* name, const H5L_info_t*, void* out) -> herr_t {
    static_cast<std::vector<std::string>*>(out)->emplace_back(name);
    return 0;
  };
  H5Literate(group, H5_INDEX_NAME, H5_ITER_INC, nullptr, collect, &names);
  return names;
}

}  // namespace fissure::formats::h5
