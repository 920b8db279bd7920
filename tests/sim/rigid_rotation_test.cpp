// The arc update of sim/rigid_rotation.h: a rigid turn becomes an exact rotation, a
// deformation is carried unchanged, and what it must keep (centre of mass, momentum,
// kinetic energy) is kept to rounding.
#include "player/sim/rigid_rotation.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <vector>

namespace fissure::sim {
namespace {

/// Two groups of four nodes each: a tet at the origin and one at (2, 0, 0).
struct TwoTets {
  Matrix3Xd start = Matrix3Xd(3, 8);
  Eigen::VectorXd mass = Eigen::VectorXd(8);
  std::vector<std::uint8_t> pinned = std::vector<std::uint8_t>(8, 0);
  std::vector<Index> group = {0, 0, 0, 0, 1, 1, 1, 1};
  TwoTets() {
    start << 0, 1, 0, 0, 2, 3, 2, 2,  //
        0, 0, 1, 0, 0, 0, 1, 0,       //
        0, 0, 0, 1, 0, 0, 0, 1;
    mass << 1, 2, 3, 4, 1, 1, 1, 1;
  }
  [[nodiscard]] Vec3 centre(const Matrix3Xd& x, Index g) const {
    Vec3 sum = Vec3::Zero();
    double m = 0;
    for (Index n = 0; n < 8; ++n) {
      if (group[n] == g) sum += mass[n] * x.col(n), m += mass[n];
    }
    return sum / m;
  }
};

double pair_distance_error(const Matrix3Xd& a, const Matrix3Xd& b, Index first) {
  double worst = 0;
  for (Index i = first; i < first + 4; ++i) {
    for (Index j = i + 1; j < first + 4; ++j) {
      worst = std::max(worst, std::abs((a.col(i) - a.col(j)).norm() - (b.col(i) - b.col(j)).norm()));
    }
  }
  return worst;
}

TEST(RigidRotation, ALinearisedTurnBecomesAnExactRotationKeepingMomentumWithoutGainingEnergy) {
  TwoTets t;
  const double h = 0.1;
  const Vec3 omega(0.3, -2.0, 5.0), drift(0.5, 0, -1);
  Matrix3Xd v(3, 8);
  const Vec3 c = t.centre(t.start, 0);
  for (Index n = 0; n < 8; ++n) v.col(n) = n < 4 ? Vec3(drift + omega.cross(t.start.col(n) - c)) : Vec3::Zero();
  Matrix3Xd x = t.start + h * v;
  ASSERT_GT(pair_distance_error(x, t.start, 0), 1e-2);  // the line stretched the tet
  const Vec3 momentum = v * t.mass;
  const auto kinetic = [&] { return 0.5 * (v.colwise().squaredNorm().transpose().array() * t.mass.array()).sum(); };
  const auto spin_momentum = [&] {  // angular, about the group's centre
    Vec3 l = Vec3::Zero();
    for (Index n = 0; n < 4; ++n) l += t.mass[n] * (x.col(n) - t.centre(x, 0)).cross(v.col(n) - drift);
    return l;
  };
  const double kinetic_before = kinetic();
  const Vec3 spin_before = spin_momentum();
  const Matrix3Xd untouched = x.rightCols(4);

  const double angle = rotate_rigid_parts(t.start, t.mass, t.pinned, t.group, 2, x, v);

  EXPECT_NEAR(angle, h * omega.norm(), 1e-12);
  EXPECT_LT(pair_distance_error(x, t.start, 0), 1e-14);                 // a rotation: no strain
  EXPECT_LT((t.centre(x, 0) - (c + h * drift)).norm(), 1e-14);          // the centre moved as before
  EXPECT_LT((v * t.mass - momentum).norm(), 1e-13);
  EXPECT_LE(kinetic(), kinetic_before * (1 + 1e-12));
  // The spin keeps its angular momentum's direction (and its size, unless keeping it
  // would gain energy), and stays a rigid spin about the new positions: no stretch.
  const Vec3 spin_after = spin_momentum();
  EXPECT_LT(spin_after.normalized().cross(spin_before.normalized()).norm(), 1e-12);
  EXPECT_LE(spin_after.norm(), spin_before.norm() * (1 + 1e-12));
  for (Index i = 0; i < 4; ++i) {
    for (Index j = i + 1; j < 4; ++j) {  // a rigid field keeps every distance: d|xi − xj|²/dt = 0
      EXPECT_NEAR((x.col(i) - x.col(j)).dot(v.col(i) - v.col(j)), 0.0, 1e-12) << i << " " << j;
    }
  }
  EXPECT_EQ(x.rightCols(4), untouched);  // the resting group is left bit for bit
}

TEST(RigidRotation, ADeformationIsCarriedUnchangedInTheTurnedFrame) {
  TwoTets t;
  const Vec3 c = t.centre(t.start, 0);
  const Vec3 theta(0.1, 0.2, 0.4);
  // A 10 % swelling about the centre has no rotational part: alone, it is left as it is.
  Matrix3Xd swollen = t.start, v = Matrix3Xd::Zero(3, 8);
  for (Index n = 0; n < 4; ++n) swollen.col(n) = c + 1.1 * (t.start.col(n) - c);
  Matrix3Xd x = swollen;
  EXPECT_EQ(rotate_rigid_parts(t.start, t.mass, t.pinned, t.group, 2, x, v), 0.0);
  EXPECT_EQ(x, swollen);
  // With a linearised turn on top, the result is the swollen tet turned exactly.
  for (Index n = 0; n < 4; ++n) x.col(n) = swollen.col(n) + theta.cross(t.start.col(n) - c);
  EXPECT_NEAR(rotate_rigid_parts(t.start, t.mass, t.pinned, t.group, 2, x, v), theta.norm(), 1e-14);
  const Eigen::AngleAxisd turn(theta.norm(), theta.normalized());
  for (Index n = 0; n < 4; ++n) EXPECT_LT((x.col(n) - (c + turn * (swollen.col(n) - c))).norm(), 1e-14) << n;
}

TEST(RigidRotation, ARigidGroupKeepsItsShapeAndItsMomentaAndLosesOnlyItsFlex) {
  // solver.rigid_fragments_below: a turn, a drift and a swelling in one step; the rigid
  // group keeps the start's shape (so its strain), its centre's motion and its linear
  // momentum, and its velocities become a rigid field with no more kinetic energy.
  TwoTets t;
  const double h = 0.05;
  const Vec3 omega(1.0, -4.0, 2.5), drift(0.2, -0.3, 0.1);
  const Vec3 c = t.centre(t.start, 0);
  Matrix3Xd v(3, 8);
  for (Index n = 0; n < 8; ++n) {
    const Vec3 r = t.start.col(n) - c;
    v.col(n) = n < 4 ? Vec3(drift + omega.cross(r) + 0.8 * r) : Vec3::Zero();  // 0.8 r: swelling
  }
  Matrix3Xd x = t.start + h * v;
  const Vec3 momentum = v * t.mass;
  const auto kinetic = [&] { return 0.5 * (v.colwise().squaredNorm().transpose().array() * t.mass.array()).sum(); };
  const double kinetic_before = kinetic();
  const Matrix3Xd untouched = x.rightCols(4);
  const std::vector<std::uint8_t> rigid = {1, 0};

  rotate_rigid_parts(t.start, t.mass, t.pinned, t.group, 2, x, v, rigid);

  EXPECT_LT(pair_distance_error(x, t.start, 0), 1e-14);         // the start's shape: no new strain
  EXPECT_LT((t.centre(x, 0) - (c + h * drift)).norm(), 1e-14);  // the swelling moved no centre
  EXPECT_LT((v * t.mass - momentum).norm(), 1e-13);
  EXPECT_LT(kinetic(), kinetic_before);  // the swelling's share is gone
  for (Index i = 0; i < 4; ++i) {
    for (Index j = i + 1; j < 4; ++j) {
      EXPECT_NEAR((x.col(i) - x.col(j)).dot(v.col(i) - v.col(j)), 0.0, 1e-12) << i << " " << j;
    }
  }
  EXPECT_EQ(x.rightCols(4), untouched);
}

TEST(RigidRotation, ARigidGroupThatDoesNotTurnStillLosesItsFlex) {
  // Below the smallest rotation a deformable group is left alone; a rigid one is not.
  TwoTets t;
  const Vec3 c = t.centre(t.start, 0);
  Matrix3Xd v = Matrix3Xd::Zero(3, 8);
  for (Index n = 0; n < 4; ++n) v.col(n) = 0.5 * (t.start.col(n) - c);
  Matrix3Xd x = t.start + 0.1 * v;
  const std::vector<std::uint8_t> rigid = {1, 1};
  EXPECT_EQ(rotate_rigid_parts(t.start, t.mass, t.pinned, t.group, 2, x, v, rigid), 0.0);
  EXPECT_LT(pair_distance_error(x, t.start, 0), 1e-15);
  EXPECT_LT(v.norm(), 1e-15);  // a pure swelling has no rigid part
}

TEST(RigidRotation, AGroupWithAPinnedNodeIsLeftAsItWas) {
  TwoTets t;
  t.pinned[2] = 1;
  Matrix3Xd v = Matrix3Xd::Zero(3, 8);
  for (Index n = 0; n < 4; ++n) v.col(n) = Vec3::UnitZ().cross(t.start.col(n));
  Matrix3Xd x = t.start + 0.5 * v;
  const Matrix3Xd before = x, v_before = v;
  EXPECT_EQ(rotate_rigid_parts(t.start, t.mass, t.pinned, t.group, 2, x, v), 0.0);
  EXPECT_EQ(x, before);
  EXPECT_EQ(v, v_before);
}

}  // namespace
}  // namespace fissure::sim
