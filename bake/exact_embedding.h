#pragma once
/// The exact geometry of the embedding, on CGAL's exact predicates (thesis III.B and
/// the contour lines of III.C). This header is CGAL-free; exact_embedding.cpp is one of
/// the few translation units that include CGAL.

#include <cstddef>
#include <array>
#include <cstdint>
#include <vector>

#include "common/surface_mesh.h"
#include "common/tet_mesh.h"
#include "formats/bundle.h"

namespace fissure::bake {

using formats::kContourInterior;

/// Every (triangle, tet) pair whose closed point sets intersect, sorted by triangle
/// then tet. Candidates come from CGAL's box intersection (never all pairs); each is
/// confirmed with CGAL::do_intersect(Triangle_3, Tetrahedron_3) on exact predicates.
///
/// A triangle lying exactly in an interior cage face touches both tets of that face;
/// it is kept only in the tet behind it (opposite its normal, on the solid's side),
/// so every bit of surface is stored once per tet it really occupies.
struct TriangleTetPairs {
  std::vector<TriangleIndex> triangle;
  std::vector<TetIndex> tet;
  /// Per pair, column j = barycentric coordinates of vertex j w.r.t. the tet.
  /// Coordinates that are exactly zero (the vertex lies in that face's plane, by an
  /// exact orientation test) are stored as exactly 0, and rounding never flips a
  /// coordinate's sign, so clipping in barycentric space agrees with the exact geometry.
  std::vector<Eigen::Matrix<double, 4, 3>> barycentric;
  std::size_t candidates = 0;             ///< box-overlap pairs tested exactly
  std::size_t degenerate_triangles = 0;   ///< collinear triangles, skipped (they cover no area)
  std::size_t coplanar_dropped = 0;       ///< in-face touches assigned to the other tet of the face
};

TriangleTetPairs assign_triangles(const SurfaceMesh& mesh, const TetMesh& cage, const CageFaces& faces);

/// Exact segments where the surface crosses cage faces, grouped by face (CSR).
/// Each segment is oriented so that, seen from the side the face normal
/// (faces.nodes order) points to, the solid lies to the left of the segment
/// (the side opposite the triangle's normal).
struct FaceContours {
  std::vector<std::uint64_t> offsets;                  ///< #faces + 1
  std::vector<Eigen::Matrix<double, 3, 2>> points;     ///< per segment, end points [m]
  /// Per segment end point: where on its face it lies (see formats::kContourInterior).
  std::vector<std::array<std::uint8_t, 2>> features;
  std::vector<TriangleIndex> triangle;                 ///< per segment
  std::size_t coplanar_pairs = 0;  ///< triangles lying in a face's plane (no segment: they are the wall)
  /// #faces: 1 where a render triangle lies in the face's plane (a surface aligned
  /// with the cage); such a face's inside region is not well defined.
  std::vector<std::uint8_t> degenerate_faces;
};

FaceContours extract_contours(const SurfaceMesh& mesh, const TetMesh& cage, const CageFaces& faces,
                              const TriangleTetPairs& pairs);

}  // namespace fissure::bake
