#include "player/sim/loose_nodes.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include "player/sim/implicit_integrator.h"
#include "tests/support/procedural.h"

namespace fissure::sim {
namespace {

/// A 2×1×1 box of tets whose last tet hangs by its corner 0 alone: its other three
/// corners were split off onto nodes of their own (fracture leaves such hinges).
struct HangingTet {
  HangingTet()
      : cage(testing::grid_cage(Vec3::Zero(), Vec3(0.04, 0.02, 0.02), 8, 4, 4)),
        body(cage.rest_positions, cage.tets, Material{.youngs_modulus = 2e7}),
        tet(static_cast<TetIndex>(cage.tets.cols() - 1)),
        hinge(cage.tets(0, tet)) {
    for (int corner = 1; corner < 4; ++corner) {
      const std::pair<TetIndex, int> slot{tet, corner};
      free_corners[corner - 1] = body.split_node(cage.tets(corner, tet), std::span(&slot, 1));
    }
  }
  TetMesh cage;
  ImplicitIntegrator body;
  TetIndex tet;
  NodeIndex hinge;
  std::array<NodeIndex, 3> free_corners{};
};

StepSettings cg_settings() {
  StepSettings s;
  s.dt = 1.0 / 240.0;
  s.solver = LinearSolver::ConjugateGradient;
  s.preconditioner = Preconditioner::LaggedCholesky;
  s.tolerance = 1e-10;
  s.loose_node_slots = 1;
  s.gravity.setZero();
  return s;
}

Eigen::VectorXd random_vector(Eigen::Index size, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n;
  Eigen::VectorXd v(size);
  for (Eigen::Index i = 0; i < size; ++i) v[i] = n(rng);
  return v;
}

TEST(LooseNodes, FindsTheNodesOfAHangingTetInOnePartAndLeavesTheHingeInTheCore) {
  HangingTet h;
  ASSERT_EQ(h.body.step(cg_settings()), SolveStatus::Converged);  // builds the pattern
  BlockSystem system;
  std::vector<std::uint8_t> pinned(h.body.node_count(), 0);
  system.build(h.body.elasticity().tets(), pinned);
  LooseNodes loose;
  loose.find(h.body.elasticity().tets(), system, 1, 64);
  for (const NodeIndex n : h.free_corners) EXPECT_TRUE(loose.loose(system.row(n) / 3)) << "node " << n;
  EXPECT_FALSE(loose.loose(system.row(h.hinge) / 3));
  const std::size_t with_corners = loose.loose_count();
  loose.find(h.body.elasticity().tets(), system, 1, 2);
  for (const NodeIndex n : h.free_corners) EXPECT_FALSE(loose.loose(system.row(n) / 3)) << "a part over the limit stays in the core";
  EXPECT_EQ(loose.loose_count(), with_corners - 3);
  loose.find(h.body.elasticity().tets(), system, 0, 64);
  EXPECT_TRUE(loose.empty());
}

TEST(LooseNodes, WithAFreshFactorThePreconditionerIsTheExactInverse) {
  HangingTet h;
  ASSERT_EQ(h.body.step(cg_settings()), SolveStatus::Converged);  // factors A afresh (the pattern changed)
  const Eigen::VectorXd x = random_vector(h.body.system_size(), 3);
  Eigen::VectorXd ax, z;
  h.body.multiply_system(x, ax);
  h.body.precondition_system(ax, z);
  EXPECT_LT((z - x).norm(), 1e-9 * x.norm());
}

TEST(LooseNodes, ASwungTetKeepsThePreconditionerSymmetricPositiveDefinite) {
  HangingTet h;
  const StepSettings s = cg_settings();
  ASSERT_EQ(h.body.step(s), SolveStatus::Converged);
  const int factorizations = h.body.factorizations();
  // The tet swings 1 rad about its hinge since the factor was made, and spins on: the
  // factor is the old one, the loose part's blocks are this step's.
  Matrix3Xd x = h.body.positions();
  const Vec3 pivot = x.col(h.hinge);
  const Mat3 turn = Eigen::AngleAxisd(1.0, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  for (const NodeIndex n : h.free_corners) x.col(n) = pivot + turn * (x.col(n) - pivot);
  h.body.set_positions(x);
  Matrix3Xd v = Matrix3Xd::Zero(3, x.cols());
  for (const NodeIndex n : h.free_corners) v.col(n) = Vec3(0, 0, 300.0).cross(x.col(n) - pivot);
  h.body.set_velocities(v);
  ASSERT_EQ(h.body.step(s), SolveStatus::Converged);
  ASSERT_EQ(h.body.factorizations(), factorizations) << "the lagged factor must still be the old one";
  const Eigen::VectorXd a = random_vector(h.body.system_size(), 5), b = random_vector(h.body.system_size(), 6);
  Eigen::VectorXd za, zb;
  h.body.precondition_system(a, za);
  h.body.precondition_system(b, zb);
  EXPECT_NEAR(b.dot(za), a.dot(zb), 1e-9 * std::abs(b.dot(za)));
  EXPECT_GT(a.dot(za), 0.0);
  EXPECT_GT(b.dot(zb), 0.0);
}

}  // namespace
}  // namespace fissure::sim
