#include "bake/winding_number.h"

#include <gtest/gtest.h>

#include <random>

#include "bake/mesh_import.h"
#include "formats/cage_io.h"
#include "tests/support/procedural.h"

namespace fissure::bake {
namespace {

TEST(WindingNumber, OneInsideZeroOutsideAClosedSphere) {
  const SurfaceMesh sphere = testing::icosphere(3, 1.0);
  const WindingNumberTree tree(sphere);
  EXPECT_NEAR(tree.winding_number_direct(Vec3::Zero()), 1.0, 1e-12);
  EXPECT_NEAR(tree.winding_number_direct(Vec3(0.3, -0.5, 0.2)), 1.0, 1e-12);
  EXPECT_NEAR(tree.winding_number_direct(Vec3(2.0, 0.1, 0.0)), 0.0, 1e-12);
  EXPECT_NEAR(tree.winding_number(Vec3(0.3, -0.5, 0.2)), 1.0, 2e-2);
  EXPECT_NEAR(tree.winding_number(Vec3(5.0, 4.0, 0.0)), 0.0, 1e-3);
}

TEST(WindingNumber, TreeConvergesToTheDirectSumAsAccuracyGrows) {
  const auto mesh = import_render_mesh(testing::data_dir() / "meshes" / "bunny-5k.obj").mesh;
  const Vec3 lo = mesh.positions.rowwise().minCoeff(), hi = mesh.positions.rowwise().maxCoeff();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.1, 1.1);
  std::vector<Vec3> points;
  for (int i = 0; i < 500; ++i) points.push_back(lo + (hi - lo).cwiseProduct(Vec3(u(rng), u(rng), u(rng))));
  double previous = 1.0;
  for (const double beta : {2.0, 3.0, 4.0, 6.0}) {
    const WindingNumberTree tree(mesh, beta);
    double worst = 0.0;
    for (const Vec3& p : points) worst = std::max(worst, std::abs(tree.winding_number(p) - tree.winding_number_direct(p)));
    EXPECT_LT(worst, previous) << "beta " << beta;
    previous = worst;
  }
  EXPECT_LT(previous, 2e-3);
}

TEST(WindingNumber, DefaultTreeClassifiesCageNodesLikeTheDirectSum) {
  const auto mesh = import_render_mesh(testing::data_dir() / "meshes" / "bunny-5k.obj").mesh;
  const auto cage = formats::read_cage(testing::data_dir() / "cages" / "bunny-5k-cage-987.node").mesh;
  const WindingNumberTree tree(mesh);
  for (Index n = 0; n < cage.node_count(); ++n) {
    const Vec3 p = cage.rest_positions.col(n);
    EXPECT_EQ(tree.winding_number(p) >= 0.5, tree.winding_number_direct(p) >= 0.5) << "node " << n;
  }
}

TEST(WindingNumber, HoleGivesAboutOneHalfAtItsCentre) {
  // A hemisphere-like open surface: the winding number at the rim's centre is 1/2.
  SurfaceMesh sphere = testing::icosphere(3, 1.0);
  Matrix3Xu kept(3, 0);
  std::vector<Index> keep;
  for (Index t = 0; t < sphere.triangle_count(); ++t) {
    Vec3 c = Vec3::Zero();
    for (int k = 0; k < 3; ++k) c += sphere.positions.col(sphere.triangles(k, t));
    if (c.z() > 0.0) keep.push_back(t);
  }
  kept.resize(3, static_cast<Eigen::Index>(keep.size()));
  for (std::size_t i = 0; i < keep.size(); ++i) kept.col(static_cast<Eigen::Index>(i)) = sphere.triangles.col(keep[i]);
  sphere.triangles = kept;
  const WindingNumberTree tree(sphere);
  EXPECT_NEAR(tree.winding_number_direct(Vec3::Zero()), 0.5, 0.02);
  EXPECT_NEAR(tree.winding_number(Vec3(0, 0, 0.5)), tree.winding_number_direct(Vec3(0, 0, 0.5)), 5e-3);
}

}  // namespace
}  // namespace fissure::bake
