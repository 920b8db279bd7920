#pragma once
/// PLY (Stanford polygon) files, read by Fissure itself rather than assimp: assimp 5.2's
/// PLY reader crashed on 44% of mutated files and spun forever on a header without
/// `end_header` (issue 17). This one checks every count against the bytes left before
/// it allocates, and every index against the vertex count.
///
/// Reads ascii, binary_little_endian and binary_big_endian 1.0: element `vertex` with
/// x, y, z (any scalar type) and optional nx, ny, nz and u, v (or s, t, or texture_u,
/// texture_v); element `face` with a list property `vertex_indices` (or
/// `vertex_index`). Polygons are split into triangle fans; other elements and
/// properties are skipped.

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include "common/surface_mesh.h"

namespace fissure::formats {

struct PlyMesh {
  SurfaceMesh mesh;
  std::size_t skipped_faces = 0;  ///< faces of fewer than 3 vertices (points, edges)
};

/// Throws fissure::Error naming the file and the header line, or the element and its
/// index, with a hint.
PlyMesh read_ply(const std::filesystem::path& path);

/// Same, from bytes in memory; `name` prefixes every error (tests, fuzzing).
PlyMesh parse_ply(std::string_view bytes, const std::string& name);

}  // namespace fissure::formats
