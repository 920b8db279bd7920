#pragma once
/// Barycentric coordinates with respect to a tetrahedron (thesis eq. 3.1–3.2) and the
/// clipping of an embedded triangle to its tet, done in barycentric space so it needs
/// nothing but the bundle's data.

#include <vector>

#include "common/types.h"

namespace fissure {

/// Maps points to barycentric coordinates of one tet. Precomputes the inverse of the
/// edge matrix [p1-p0, p2-p0, p3-p0] once per tet (cheaper and better conditioned than
/// the thesis's Cramer's rule per point).
class TetBarycentricFrame {
 public:
  TetBarycentricFrame(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);

  /// β with p = Σ βᵢ pᵢ. β₀ is set to 1 − β₁ − β₂ − β₃, so the sum is 1 up to one rounding.
  [[nodiscard]] Vec4 coordinates(const Vec3& p) const;

 private:
  Vec3 m_origin;
  Mat3 m_inverse_edges;
};

/// p = Σ βᵢ nodes.col(i) for a 3×4 matrix of tet node positions.
inline Vec3 from_barycentric(const Eigen::Matrix<double, 3, 4>& nodes, const Vec4& beta) { return nodes * beta; }

/// Clips the triangle whose vertices have barycentric coordinates `triangle` (columns)
/// to the tet {β ≥ 0}. Returns the polygon's vertices in barycentric coordinates, in
/// order; empty when the overlap has no area-carrying part left.
std::vector<Vec4> clip_to_tet(const Eigen::Matrix<double, 4, 3>& triangle);

/// Area [m²] of a planar polygon given in barycentric coordinates of the tet `nodes`.
double polygon_area(const std::vector<Vec4>& polygon, const Eigen::Matrix<double, 3, 4>& nodes);

}  // namespace fissure
