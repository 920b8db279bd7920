#pragma once
/// The render (surface) mesh: what the player draws, what the bake embeds.

#include <cstddef>
#include <vector>

#include "common/types.h"

namespace fissure {

struct SurfaceMesh {
  Matrix3Xd positions;  ///< 3×#V vertex positions [m]
  Matrix3Xu triangles;  ///< 3×#F vertex indices, counter-clockwise seen from outside
  Matrix3Xd normals;    ///< 3×#V unit normals, or empty when the source had none
  Matrix2Xd uvs;        ///< 2×#V texture coordinates, or empty when the source had none

  [[nodiscard]] std::size_t vertex_count() const { return static_cast<std::size_t>(positions.cols()); }
  [[nodiscard]] std::size_t triangle_count() const { return static_cast<std::size_t>(triangles.cols()); }
};

/// Area of triangle t [m²].
double triangle_area(const SurfaceMesh& mesh, TriangleIndex t);

/// A triangle with (numerically) no area: area ≤ 1e-12 · (longest edge)². Such
/// triangles draw nothing; the bake stores no instance for the exactly collinear ones
/// and coverage checks skip them all.
bool is_degenerate(const SurfaceMesh& mesh, TriangleIndex t);

/// Topology of the surface seen through vertex positions (vertices at bit-identical
/// positions count as one, so an importer's split seams do not look like holes).
struct SurfaceTopology {
  std::size_t edges = 0;
  std::size_t boundary_edges = 0;     ///< used by exactly one triangle
  std::size_t boundary_loops = 0;     ///< connected chains of boundary edges (holes)
  std::size_t nonmanifold_edges = 0;  ///< used by three or more triangles
  std::size_t degenerate_triangles = 0;  ///< repeated vertex or zero area
  [[nodiscard]] bool closed() const { return boundary_edges == 0 && nonmanifold_edges == 0; }
};

SurfaceTopology analyze_topology(const SurfaceMesh& mesh);

/// For every vertex, the smallest index of a vertex at the bit-identical position.
std::vector<Index> position_representatives(const Matrix3Xd& positions);

/// A triangle that bounds nothing: two corners at one position (through `representatives`
/// from position_representatives) or is_degenerate. Surface repair and the
/// self-intersection count leave such triangles out.
bool bounds_nothing(const SurfaceMesh& mesh, const std::vector<Index>& representatives, TriangleIndex t);

}  // namespace fissure
