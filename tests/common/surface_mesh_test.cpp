#include "common/surface_mesh.h"

#include <gtest/gtest.h>

#include <numbers>

#include "tests/support/procedural.h"

namespace fissure {
namespace {

TEST(SurfaceTopology, IcosphereIsClosed) {
  const SurfaceMesh sphere = testing::icosphere(2);
  const SurfaceTopology topology = analyze_topology(sphere);
  EXPECT_TRUE(topology.closed());
  EXPECT_EQ(topology.edges, 3 * sphere.triangle_count() / 2);
}

TEST(SurfaceTopology, ProceduralBoxIsClosed) {
  EXPECT_TRUE(analyze_topology(testing::box_surface(Vec3(-0.9, -0.9, -0.9), Vec3(0.9, 0.9, 0.3), 6)).closed());
}

TEST(SurfaceTopology, RemovingTrianglesOpensHoles) {
  SurfaceMesh sphere = testing::icosphere(2);
  // Drop triangle 0 and one far from it: two separate holes of 3 edges each.
  Matrix3Xu kept(3, sphere.triangles.cols() - 2);
  Eigen::Index out = 0;
  for (Eigen::Index t = 0; t < sphere.triangles.cols(); ++t) {
    if (t != 0 && t != sphere.triangles.cols() - 1) kept.col(out++) = sphere.triangles.col(t);
  }
  sphere.triangles = kept;
  const SurfaceTopology topology = analyze_topology(sphere);
  EXPECT_EQ(topology.boundary_edges, 6u);
  EXPECT_EQ(topology.boundary_loops, 2u);
  EXPECT_FALSE(topology.closed());
}

TEST(SurfaceTopology, SplitSeamsDoNotLookLikeHoles) {
  // Duplicate every vertex per triangle (as importers do at UV seams): positions
  // still weld, so the surface stays closed.
  const SurfaceMesh sphere = testing::icosphere(1);
  SurfaceMesh split;
  split.positions.resize(3, 3 * sphere.triangles.cols());
  split.triangles.resize(3, sphere.triangles.cols());
  for (Eigen::Index t = 0; t < sphere.triangles.cols(); ++t) {
    for (int k = 0; k < 3; ++k) {
      split.positions.col(3 * t + k) = sphere.positions.col(sphere.triangles(k, t));
      split.triangles(k, t) = static_cast<Index>(3 * t + k);
    }
  }
  EXPECT_TRUE(analyze_topology(split).closed());
}

TEST(SurfaceMesh, IcosphereAreaApproachesSphereArea) {
  double previous_error = 1.0;
  for (int level = 1; level <= 4; ++level) {
    const SurfaceMesh sphere = testing::icosphere(level);
    double area = 0.0;
    for (Index t = 0; t < sphere.triangle_count(); ++t) area += triangle_area(sphere, t);
    const double error = std::abs(area - 4.0 * std::numbers::pi) / (4.0 * std::numbers::pi);
    EXPECT_LT(error, previous_error);
    previous_error = error;
  }
  EXPECT_LT(previous_error, 0.01);
}

}  // namespace
}  // namespace fissure
