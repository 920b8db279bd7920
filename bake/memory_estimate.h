#pragma once
/// The memory a bake or a cage will need, estimated from the mesh file before it is
/// read (issue 43: a mesh of 10 million triangles on a machine that cannot hold it is
/// a clear error naming the file and the flag, not an out-of-memory kill half-way).

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

namespace fissure::bake {

/// Measured peak memory (development machine, `/usr/bin/time -f %M`): bunny-5k 43 MB,
/// a 1M-triangle OBJ 595 MB (import dominates), the bunny's bake at 20,000 tets 179 MB
/// against 43 MB at 1,000. Rounded up so the estimate errs high.
inline constexpr std::uint64_t kBaseBytes = std::uint64_t{64} << 20;
inline constexpr std::uint64_t kBytesPerTriangle = 700;
inline constexpr std::uint64_t kBytesPerTet = 8 << 10;

struct MemoryEstimate {
  std::uint64_t triangles = 0;  ///< read from a header, or estimated from the file's size
  std::string basis;            ///< how: "its header says", "from its size"
  std::uint64_t bytes = 0;
};

/// Triangles from the header where the format has one (binary STL: the count, capped by
/// what the file's size can hold; PLY: `element face`), else from the file's size (OBJ
/// ~32 bytes a triangle, ASCII STL ~80, any other ~12): an estimate, never a read of the
/// whole file. `tets`: the cage asked for (0: a cage file, counted as nothing).
MemoryEstimate estimate_bake_memory(const std::filesystem::path& mesh, std::size_t tets);

/// The machine's memory: physical, or its cgroup's limit or the process's address-space
/// limit (ulimit -v) where lower.
std::uint64_t machine_memory_bytes();

/// Throws fissure::Error naming `mesh`, the estimate and `--memory-limit` when the
/// estimate is past `limit_bytes` (0: no limit). Nothing has been read or written then.
void check_bake_memory(const std::filesystem::path& mesh, std::size_t tets, std::uint64_t limit_bytes);

}  // namespace fissure::bake
