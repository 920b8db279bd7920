#pragma once
/// Input files for every reader: only regular files, read with a size cap. A FIFO, a
/// device (/dev/zero, a terminal) or a socket can stream without end; reading one used
/// to grow until memory ran out (issue 46). The readers refuse them before opening.

#include <cstdint>
#include <filesystem>
#include <string>

namespace fissure {

/// The most any reader loads into memory at once: far above any real scene, cage or
/// mesh text, and below what would exhaust a workstation.
inline constexpr std::uint64_t kMaxInputBytes = std::uint64_t{4} << 30;

/// "a FIFO (named pipe)", "a character device", … for a path that exists and is not a
/// regular file or a directory; empty otherwise.
std::string special_file_kind(const std::filesystem::path& path);

/// Throws fissure::Error naming `path` when it does not exist, is a directory, or is
/// not a regular file (a FIFO, a device, a socket), with what to do.
void require_regular_input(const std::filesystem::path& path);

/// The whole file, after require_regular_input. Throws fissure::Error when it holds
/// more than `max_bytes` (a file that grows while being read counts too) or cannot be read.
std::string read_input_file(const std::filesystem::path& path, std::uint64_t max_bytes = kMaxInputBytes);

}  // namespace fissure
