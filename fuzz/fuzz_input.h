#pragma once
/// Shared by the libFuzzer targets (fuzz/*.cpp): the readers take paths, so each input
/// is written to one temporary file per process and per name, and read back through
/// the same function the CLIs call.
///
/// The contract every target checks: any bytes end in a parsed result or a
/// fissure::Error. Any other exception (bad_alloc, out_of_range …) escapes to libFuzzer
/// and is reported as a crash, like a signal or a sanitizer finding.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace fissure::fuzz {

/// Writes `bytes` to `<tmp>/fissure-fuzz-<pid>-<name>` and returns that path. The
/// file is overwritten on each call and removed at exit.
std::filesystem::path write_input(std::string_view bytes, const std::string& name);

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

}  // namespace fissure::fuzz
