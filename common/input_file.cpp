#include "common/input_file.h"

#include <cerrno>
#include <cstring>
#include <fstream>

#include "common/error.h"

namespace fissure {

std::string special_file_kind(const std::filesystem::path& path) {
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  switch (status.type()) {
    case std::filesystem::file_type::fifo: return "a FIFO (named pipe)";
    case std::filesystem::file_type::character: return "a character device";
    case std::filesystem::file_type::block: return "a block device";
    case std::filesystem::file_type::socket: return "a socket";
    case std::filesystem::file_type::unknown: return "not a regular file";
    default: return {};
  }
}

void require_regular_input(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  if (ec && ec != std::errc::no_such_file_or_directory) {
    throw Error(name + ": cannot be read: " + ec.message(), "check the path (a symbolic link to itself?) and permissions");
  }
  if (!std::filesystem::exists(status)) {
    throw Error(name + ": file not found", "check the path; relative paths are resolved from the working directory");
  }
  if (std::filesystem::is_directory(path, ec)) throw Error(name + ": is a directory, not a file");
  const std::string kind = special_file_kind(path);
  if (!kind.empty()) {
    throw Error(name + ": is " + kind + ", not a regular file; Fissure reads inputs only from regular files",
                "save the data to a file first (a stream or device can be endless)");
  }
}

std::string read_input_file(const std::filesystem::path& path, std::uint64_t max_bytes) {
  require_regular_input(path);
  const std::string name = path.string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(name + ": cannot open the file for reading: " + std::strerror(errno), "check its permissions");
  std::string bytes;
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (!ec && size <= max_bytes) bytes.reserve(static_cast<std::size_t>(size));
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    bytes.append(buffer, static_cast<std::size_t>(in.gcount()));
    if (bytes.size() > max_bytes) {
      throw Error(name + ": larger than " + std::to_string(max_bytes >> 20) + " MiB, the most Fissure reads at once",
                  "split or simplify the input");
    }
  }
  if (in.bad()) throw Error(name + ": cannot read the file");
  return bytes;
}

}  // namespace fissure
