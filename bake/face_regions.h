#pragma once
/// The part of each cage face that lies inside the solid (thesis III.C: the walls a
/// fracture exposes), as closed oriented boundaries: the exact contour segments plus
/// the pieces of the face's edges that are inside. Used to rasterize wall tiles, to
/// class faces, and to integrate the solid part of each tet (mass properties).

#include <array>
#include <cstdint>
#include <vector>

#include "formats/bundle.h"

namespace fissure::bake {

using formats::FaceClass;

struct FaceRegions {
  std::vector<FaceClass> face_class;  ///< #faces
  std::vector<double> inside_area;    ///< #faces, area of face ∩ solid [m²]
  /// Boundary pieces of each face's inside region (CSR over faces), oriented so the
  /// inside is on their left seen from the face normal (faces.nodes order): contour
  /// segments and inside edge pieces together form closed loops.
  std::vector<std::uint64_t> offsets;
  std::vector<Eigen::Matrix<double, 3, 2>> pieces;
  std::size_t inconsistent_faces = 0;  ///< faces whose contours and node classes disagree (open or broken surfaces)
};

/// Builds the inside regions from the embedding's contours (their exact end-point
/// features say where a region meets the face edges) and the node classes (which
/// say, for edges no contour reaches, whether they are inside).
FaceRegions build_face_regions(const formats::Bundle& bundle);

/// Winding number of the face point x (in the face's plane) w.r.t. the region's
/// boundary pieces, with exact orientation predicates in the face's projected 2D
/// frame: non-zero means inside.
int region_winding(const FaceRegions& regions, FaceIndex face, const Vec3& face_normal, const Vec3& x);

}  // namespace fissure::bake
