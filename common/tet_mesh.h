#pragma once
/// The tetrahedral cage: rest node positions and positively oriented tets, plus
/// the face table that links tets through their shared triangles.
///
/// Local face i of a tet is the face opposite local node i, with its nodes ordered
/// counter-clockwise seen from outside the tet (outward normal):
///
///            3
///           /|\        face 0 = (1,2,3)   face 1 = (0,3,2)
///          / | \       face 2 = (0,1,3)   face 3 = (0,2,1)
///         0--|--2
///          \ | /       positive orientation: det[p1-p0, p2-p0, p3-p0] > 0
///           \|/
///            1

#include <array>
#include <cstddef>
#include <string>

#include "common/types.h"

namespace fissure {

inline constexpr std::array<std::array<int, 3>, 4> kTetFaceNodes{{{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}}};

struct TetMesh {
  Matrix3Xd rest_positions;  ///< 3×#N node positions [m]
  Matrix4Xu tets;            ///< 4×#T node indices, positively oriented

  [[nodiscard]] std::size_t node_count() const { return static_cast<std::size_t>(rest_positions.cols()); }
  [[nodiscard]] std::size_t tet_count() const { return static_cast<std::size_t>(tets.cols()); }
};

/// det[p1-p0, p2-p0, p3-p0] / 6 [m³]; positive for a positively oriented tet.
double signed_volume(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);
double signed_volume(const TetMesh& mesh, TetIndex t);

/// Relative volume below which a tet counts as degenerate: |V| <= kDegenerateRelativeVolume · L³,
/// with L its longest edge. A regular tet has V/L³ ≈ 0.118.
inline constexpr double kDegenerateRelativeVolume = 1e-10;

/// Where a cage came from, so that messages point at the line a user must edit: TetGen
/// keeps nodes and tets in two files, each numbered from 0 or 1 on its own.
struct CageSource {
  std::string tets;   ///< file the tets were read from
  std::string nodes;  ///< file the nodes were read from (the same file for one-file formats)
  std::size_t first_tet_number = 0;
  std::size_t first_node_number = 0;
};

/// Checks a freshly read cage and orients every tet positively.
/// Throws fissure::Error naming the file and the element, numbered as in the file, for:
/// no nodes or tets, non-finite coordinates, out-of-range or repeated node indices,
/// degenerate tets (with their four nodes, which is where the fix usually is).
/// Returns the number of tets that were flipped.
std::size_t validate_and_orient(TetMesh& mesh, const CageSource& source);

/// The same for a cage from one file whose tets and nodes share one numbering.
std::size_t validate_and_orient(TetMesh& mesh, const std::string& source, std::size_t first_number = 0);

/// Unique triangular faces of a cage and their adjacency.
struct CageFaces {
  Matrix3Xu nodes;      ///< 3×#faces, ordered outward from tets(0, f)
  Matrix2Xu tets;       ///< 2×#faces: the tet(s) sharing the face; row 1 is kInvalidIndex on the boundary
  Matrix4Xu tet_faces;  ///< 4×#T: face index of each local face (opposite local node i)

  [[nodiscard]] std::size_t face_count() const { return static_cast<std::size_t>(nodes.cols()); }
  [[nodiscard]] bool is_boundary(FaceIndex f) const { return tets(1, f) == kInvalidIndex; }
};

/// Area [m²] of face f of the table, at the cage's rest positions.
double face_area(const TetMesh& mesh, const CageFaces& faces, FaceIndex f);

/// Builds the face table. Faces are numbered in order of their sorted node triples,
/// so the result depends only on the cage. Throws fissure::Error if a face is shared
/// by more than two tets (a non-manifold cage).
CageFaces build_cage_faces(const TetMesh& mesh, const std::string& source);

}  // namespace fissure
