#include "bake/memory_estimate.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "common/error.h"

namespace fissure::bake {
namespace {

std::string lower_extension(const std::filesystem::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return std::tolower(c); });
  return extension;
}

/// The first `bytes` of the file (fewer where it is shorter).
std::string head_of(const std::filesystem::path& path, std::size_t bytes) {
  std::ifstream in(path, std::ios::binary);
  std::string text(bytes, '\0');
  in.read(text.data(), static_cast<std::streamsize>(bytes));
  text.resize(static_cast<std::size_t>(std::max<std::streamsize>(0, in.gcount())));
  return text;
}

/// A binary STL: 80 bytes of header, a 32-bit little-endian count, 50 bytes a triangle.
/// Assimp reads it as binary when the size fits the count; the count is capped by the
/// size, since a reader cannot make more triangles than the file holds.
bool binary_stl_triangles(const std::string& head, std::uint64_t file_bytes, std::uint64_t& triangles) {
  if (head.size() < 84) return false;
  const auto* b = reinterpret_cast<const unsigned char*>(head.data()) + 80;
  const std::uint64_t count = b[0] | (b[1] << 8) | (b[2] << 16) | (std::uint64_t{b[3]} << 24);
  const bool ascii = head.rfind("solid", 0) == 0 && file_bytes != 84 + 50 * count;
  if (ascii) return false;
  triangles = std::min(count, (file_bytes - 84) / 50);
  return true;
}

/// `element face N` of a PLY header (faces may be polygons: N is a floor).
bool ply_faces(const std::string& head, std::uint64_t& faces) {
  std::istringstream lines(head);
  for (std::string line; std::getline(lines, line) && line.rfind("end_header", 0) != 0;) {
    std::istringstream words(line);
    std::string element, name;
    unsigned long long count = 0;
    if (words >> element >> name >> count && element == "element" && name == "face") {
      faces = count;
      return true;
    }
  }
  return false;
}

std::string gib(std::uint64_t bytes) {
  char text[32];
  if (bytes < (1ull << 30)) {
    std::snprintf(text, sizeof text, "%.0f MiB", static_cast<double>(bytes) / static_cast<double>(1ull << 20));
  } else {
    std::snprintf(text, sizeof text, "%.1f GiB", static_cast<double>(bytes) / static_cast<double>(1ull << 30));
  }
  return text;
}

}  // namespace

MemoryEstimate estimate_bake_memory(const std::filesystem::path& mesh, std::size_t tets) {
  std::error_code ec;
  const std::uint64_t file_bytes = std::filesystem::file_size(mesh, ec);
  MemoryEstimate estimate;
  if (ec) return estimate;  // the reader names what is wrong with the file
  const std::string extension = lower_extension(mesh);
  const std::string head = head_of(mesh, 1 << 16);
  if (extension == ".stl" && binary_stl_triangles(head, file_bytes, estimate.triangles)) {
    estimate.basis = "its header says";
  } else if (extension == ".ply" && ply_faces(head, estimate.triangles)) {
    estimate.basis = "its header says";
  } else {
    const std::uint64_t per = extension == ".obj" ? 32 : extension == ".stl" ? 80 : 12;
    estimate.triangles = file_bytes / per;
    estimate.basis = "judging by its size, at " + std::to_string(per) + " bytes a triangle";
  }
  estimate.bytes = kBaseBytes + kBytesPerTriangle * estimate.triangles + kBytesPerTet * std::uint64_t{tets};
  return estimate;
}

std::uint64_t machine_memory_bytes() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  std::uint64_t bytes = pages > 0 && page > 0 ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page) : 0;
  // A container's limit (cgroup v2; "max" where there is none).
  std::ifstream cgroup("/sys/fs/cgroup/memory.max");
  unsigned long long limit = 0;
  if (cgroup >> limit && limit > 0 && (bytes == 0 || limit < bytes)) bytes = limit;
  // And the process's own address-space limit (ulimit -v, prlimit --as).
  rlimit address{};
  if (getrlimit(RLIMIT_AS, &address) == 0 && address.rlim_cur != RLIM_INFINITY && (bytes == 0 || address.rlim_cur < bytes)) {
    bytes = address.rlim_cur;
  }
  return bytes;
}

void check_bake_memory(const std::filesystem::path& mesh, std::size_t tets, std::uint64_t limit_bytes) {
  if (limit_bytes == 0) return;
  const MemoryEstimate estimate = estimate_bake_memory(mesh, tets);
  if (estimate.bytes <= limit_bytes) return;
  std::string what = mesh.string() + ": about " + std::to_string(estimate.triangles) + " triangles (" + estimate.basis + ")";
  if (tets > 0) what += " and " + std::to_string(tets) + " tets";
  throw Error(what + " would need about " + gib(estimate.bytes) + " of memory, past the limit of " + gib(limit_bytes) +
                  "; nothing was read or written",
              "decimate the mesh (a few hundred thousand triangles suit a real-time scene), or pass --memory-limit "
              "with more GiB than that to try anyway");
}

}  // namespace fissure::bake
