#include "common/barycentric.h"

#include <Eigen/LU>

namespace fissure {

TetBarycentricFrame::TetBarycentricFrame(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3)
    : m_origin(p0) {
  Mat3 edges;
  edges << p1 - p0, p2 - p0, p3 - p0;
  m_inverse_edges = edges.inverse();
}

Vec4 TetBarycentricFrame::coordinates(const Vec3& p) const {
  const Vec3 b = m_inverse_edges * (p - m_origin);
  return {1.0 - b.sum(), b.x(), b.y(), b.z()};
}

std::vector<Vec4> clip_to_tet(const Eigen::Matrix<double, 4, 3>& triangle) {
  // Sutherland–Hodgman against the four half-spaces βᵢ ≥ 0. Interpolating barycentric
  // coordinates keeps Σβ = 1, so no renormalisation is needed.
  std::vector<Vec4> polygon{triangle.col(0), triangle.col(1), triangle.col(2)};
  std::vector<Vec4> clipped;
  for (int i = 0; i < 4 && !polygon.empty(); ++i) {
    clipped.clear();
    for (std::size_t k = 0; k < polygon.size(); ++k) {
      const Vec4& a = polygon[k];
      const Vec4& b = polygon[(k + 1) % polygon.size()];
      const bool a_in = a[i] >= 0.0;
      const bool b_in = b[i] >= 0.0;
      if (a_in) clipped.push_back(a);
      if (a_in != b_in) {
        const double s = a[i] / (a[i] - b[i]);
        Vec4 crossing = a + s * (b - a);
        crossing[i] = 0.0;
        clipped.push_back(crossing);
      }
    }
    polygon.swap(clipped);
  }
  if (polygon.size() < 3) polygon.clear();
  return polygon;
}

double polygon_area(const std::vector<Vec4>& polygon, const Eigen::Matrix<double, 3, 4>& nodes) {
  if (polygon.size() < 3) return 0.0;
  const Vec3 origin = nodes * polygon[0];
  Vec3 twice_area = Vec3::Zero();
  Vec3 previous = nodes * polygon[1] - origin;
  for (std::size_t k = 2; k < polygon.size(); ++k) {
    const Vec3 current = nodes * polygon[k] - origin;
    twice_area += previous.cross(current);
    previous = current;
  }
  return 0.5 * twice_area.norm();
}

}  // namespace fissure
