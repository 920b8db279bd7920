#pragma once
/// Safe output files for the CLIs: check a path before the work starts, write through
/// a temporary beside it that a reader never sees half-written, and leave nothing
/// behind on failure, on SIGINT/SIGTERM/SIGHUP, or on a full disk.
///
/// Temporaries are named "<file>.tmp-<pid>". A run killed with SIGKILL cannot remove
/// its own; the next run that checks the same output path removes those whose process
/// is gone, and says so.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace fissure {

/// Once per process, before any output: SIGINT, SIGTERM and SIGHUP remove the
/// temporaries being written and then end the process as the signal would have.
/// SIGXFSZ is ignored, so a write past a file-size limit fails with EFBIG like a full
/// disk (a clean error) instead of killing the process.
void install_output_signal_handlers();

/// Throws fissure::Error, before any work, when `path` (given as `option`, e.g. "-o")
/// cannot be written: it is a directory or an existing non-regular file (a FIFO, a
/// device, a socket), its folder is missing or not writable, or it is the same file as
/// one of `inputs`. Removes stale temporaries of `path` left by
/// killed runs, with a warning. `example`: the file name the hint for a directory
/// suggests inside it, of the kind the option writes.
void check_output_path(const std::filesystem::path& path, const std::vector<std::filesystem::path>& inputs,
                       std::string_view option, std::string_view example = "out.h5");

/// A temporary file name beside `path`, registered for removal on a fatal signal while
/// this object lives. Its destructor removes the file unless `commit` renamed it.
class TemporaryOutput {
 public:
  explicit TemporaryOutput(std::filesystem::path final_path);
  ~TemporaryOutput();
  TemporaryOutput(const TemporaryOutput&) = delete;
  TemporaryOutput& operator=(const TemporaryOutput&) = delete;

  [[nodiscard]] const std::filesystem::path& path() const { return m_temporary; }
  /// Renames the temporary over the final path. Throws fissure::Error naming it, also
  /// when the final path is not a regular file (never replaced).
  void commit();

 private:
  std::filesystem::path m_final;
  std::filesystem::path m_temporary;
  int m_slot;
  bool m_committed = false;
};

/// Writes `bytes` to `path` atomically: temporary, fsync (unless `sync` is false, for
/// files cheap to remake such as video frames), rename. A full disk or an unwritable
/// folder throws fissure::Error naming `path`, leaving no file behind.
void write_file_atomically(const std::filesystem::path& path, std::string_view bytes, bool sync = true);

}  // namespace fissure
