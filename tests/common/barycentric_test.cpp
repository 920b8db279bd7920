#include "common/barycentric.h"

#include <gtest/gtest.h>

#include <random>

namespace fissure {
namespace {

Eigen::Matrix<double, 3, 4> sample_tet() {
  Eigen::Matrix<double, 3, 4> nodes;
  nodes << 0.1, 1.3, 0.2, 0.4,  //
      -0.2, 0.1, 1.1, 0.3,      //
      0.05, 0.0, 0.2, 0.9;
  return nodes;
}

TEST(TetBarycentricFrame, ReconstructsPointsAndSumsToOne) {
  const auto nodes = sample_tet();
  const TetBarycentricFrame frame(nodes.col(0), nodes.col(1), nodes.col(2), nodes.col(3));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 2.0);
  for (int i = 0; i < 100; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const Vec4 beta = frame.coordinates(p);
    EXPECT_NEAR(beta.sum(), 1.0, 1e-14);
    EXPECT_LT((from_barycentric(nodes, beta) - p).norm(), 1e-13);
  }
}

TEST(TetBarycentricFrame, NodesMapToUnitVectors) {
  const auto nodes = sample_tet();
  const TetBarycentricFrame frame(nodes.col(0), nodes.col(1), nodes.col(2), nodes.col(3));
  for (int i = 0; i < 4; ++i) {
    EXPECT_LT((frame.coordinates(nodes.col(i)) - Vec4::Unit(i)).norm(), 1e-14);
  }
}

TEST(ClipToTet, TriangleInsideKeepsItsArea) {
  const auto nodes = sample_tet();
  Eigen::Matrix<double, 4, 3> tri;
  tri.col(0) << 0.4, 0.2, 0.2, 0.2;
  tri.col(1) << 0.2, 0.4, 0.2, 0.2;
  tri.col(2) << 0.2, 0.2, 0.4, 0.2;
  const auto polygon = clip_to_tet(tri);
  ASSERT_EQ(polygon.size(), 3u);
  const Vec3 a = nodes * tri.col(0), b = nodes * tri.col(1), c = nodes * tri.col(2);
  EXPECT_NEAR(polygon_area(polygon, nodes), 0.5 * (b - a).cross(c - a).norm(), 1e-15);
}

TEST(ClipToTet, TriangleOutsideIsEmpty) {
  Eigen::Matrix<double, 4, 3> tri;
  tri.col(0) << -0.5, 0.5, 0.5, 0.5;
  tri.col(1) << -0.2, 0.6, 0.3, 0.3;
  tri.col(2) << -0.1, 0.3, 0.4, 0.4;
  EXPECT_TRUE(clip_to_tet(tri).empty());
}

TEST(ClipToTet, KeepsTheExactFractionOfAStraddlingTriangle) {
  // A triangle straddling the face β0 = 0.
  const auto nodes = sample_tet();
  Eigen::Matrix<double, 4, 3> tri;
  tri.col(0) << 0.3, 0.3, 0.2, 0.2;
  tri.col(1) << -0.3, 0.5, 0.4, 0.4;
  tri.col(2) << -0.1, 0.2, 0.5, 0.4;
  const double inside = polygon_area(clip_to_tet(tri), nodes);
  const Vec3 a = nodes * tri.col(0), b = nodes * tri.col(1), c = nodes * tri.col(2);
  const double whole = 0.5 * (b - a).cross(c - a).norm();
  // Exact fraction along the edges: β0 goes 0.3 → −0.3 and 0.3 → −0.1, so the kept
  // triangle has sides scaled by 0.5 and 0.75 at vertex 0: area ratio 0.375.
  EXPECT_NEAR(inside / whole, 0.375, 1e-14);
}

}  // namespace
}  // namespace fissure
