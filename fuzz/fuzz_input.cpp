#include "fuzz/fuzz_input.h"

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <set>
#include <stdexcept>

namespace fissure::fuzz {
namespace {

std::set<std::filesystem::path>& written_paths() {
  static std::set<std::filesystem::path> paths;
  return paths;
}

void remove_written_paths() {
  std::error_code ignored;
  for (const auto& path : written_paths()) std::filesystem::remove(path, ignored);
}

}  // namespace

std::filesystem::path write_input(std::string_view bytes, const std::string& name) {
  const auto path =
      std::filesystem::temp_directory_path() / ("fissure-fuzz-" + std::to_string(getpid()) + "-" + name);
  if (written_paths().empty()) std::atexit(remove_written_paths);
  written_paths().insert(path);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  // A harness that cannot write its input would test nothing: stop the campaign.
  if (!out.flush()) throw std::runtime_error("fuzz harness: cannot write " + path.string());
  return path;
}

}  // namespace fissure::fuzz
