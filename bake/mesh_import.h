#pragma once
/// Render-mesh import: PLY through Fissure's own reader (formats/ply.h), every other
/// format through assimp (OBJ, STL, glTF/GLB, FBX …). The only place in Fissure that
/// includes assimp.

#include <filesystem>
#include <string>

#include "common/surface_mesh.h"

namespace fissure::bake {

struct MeshImportOptions {
  /// Merge vertices at bit-identical positions even where their normals or UVs differ
  /// (seams). Off by default: vertices are only joined when every attribute is equal,
  /// which undoes the per-face splitting some importers do and loses nothing.
  bool weld = false;
};

struct ImportedMesh {
  SurfaceMesh mesh;
  std::size_t source_meshes = 0;   ///< meshes in the file, merged into one
  std::size_t skipped_primitives = 0;  ///< points and lines, which cannot be embedded
};

/// Throws fissure::Error for a missing, empty or unreadable file, an unknown format,
/// non-finite coordinates or a file without triangles.
ImportedMesh import_render_mesh(const std::filesystem::path& path, const MeshImportOptions& options = {});

}  // namespace fissure::bake
