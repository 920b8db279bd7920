// Rolling resistance (sim/rolling_resistance.h): each contact takes at most its budget
// of angular momentum out of its sides' relative spin, exactly; it never adds kinetic
// energy, keeps each fragment's centre of mass and momentum, and between two fragments
// keeps the total angular momentum.
#include "player/sim/contacts/rolling_resistance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "tests/support/sim_fixtures.h"

namespace fissure::sim {
namespace {

/// Two fragments of four nodes each (a tet at the origin and one at (2, 0, 0)), with
/// uneven masses so that inertia is not isotropic, each spinning and drifting.
struct TwoSpinningTets {
  Matrix3Xd x = Matrix3Xd(3, 8);
  Matrix3Xd v = Matrix3Xd(3, 8);
  Eigen::VectorXd mass = Eigen::VectorXd(8);
  std::vector<std::uint8_t> pinned = std::vector<std::uint8_t>(8, 0);
  std::vector<Index> fragment = {0, 0, 0, 0, 1, 1, 1, 1};
  TwoSpinningTets(const Vec3& spin_a, const Vec3& spin_b) {
    x << 0, 1, 0, 0, 2, 3, 2, 2,  //
        0, 0, 1, 0, 0, 0, 1, 0,   //
        0, 0, 0, 1, 0, 0, 0, 1;
    mass << 1, 2, 3, 4, 1, 1, 1, 1;
    const Vec3 drift(0.3, -0.1, 0.2);
    for (Index n = 0; n < 8; ++n) {
      const Index f = fragment[n];
      v.col(n) = drift + (f == 0 ? spin_a : spin_b).cross(x.col(n) - centre(f));
    }
  }
  [[nodiscard]] SpinBody body() const { return {&x, &v, &mass, pinned, fragment, 2}; }
  [[nodiscard]] Vec3 centre(Index f) const {
    Vec3 sum = Vec3::Zero();
    double m = 0;
    for (Index n = 0; n < 8; ++n) {
      if (fragment[n] == f) sum += mass[n] * x.col(n), m += mass[n];
    }
    return sum / m;
  }
  /// Angular momentum of fragment f about its centre of mass, with velocities `w`.
  [[nodiscard]] Vec3 angular(const Matrix3Xd& w, Index f) const {
    Vec3 l = Vec3::Zero();
    for (Index n = 0; n < 8; ++n) {
      if (fragment[n] == f) l += mass[n] * (x.col(n) - centre(f)).cross(w.col(n));
    }
    return l;
  }
  [[nodiscard]] Vec3 momentum(const Matrix3Xd& w, Index f) const {
    Vec3 p = Vec3::Zero();
    for (Index n = 0; n < 8; ++n) {
      if (fragment[n] == f) p += mass[n] * w.col(n);
    }
    return p;
  }
  [[nodiscard]] double kinetic(const Matrix3Xd& w) const {
    double e = 0;
    for (Index n = 0; n < 8; ++n) e += 0.5 * mass[n] * w.col(n).squaredNorm();
    return e;
  }
};

constexpr Index kStatic = kInvalidIndex;

TEST(RollingResistance, AgainstAnObstacleTakesExactlyItsBudgetOutOfTheAngularMomentum) {
  const TwoSpinningTets s(Vec3(3.0, -1.0, 2.0), Vec3::Zero());
  const SpinBody body = s.body();
  const Vec3 before = s.angular(s.v, 0);
  const double budget = 0.25 * before.norm();
  const RollingContact contact{{0, 0}, {kStatic, 0}, budget};
  const Matrix3Xd after = s.v + resist_rolling({&body, 1}, {&contact, 1})[0];
  // τ = s I ω = s L: the angular momentum keeps its direction and loses the budget.
  EXPECT_LT((s.angular(after, 0) - (1.0 - 0.25) * before).norm(), 1e-12 * before.norm());
  EXPECT_LT((s.momentum(after, 0) - s.momentum(s.v, 0)).norm(), 1e-12);
  EXPECT_LT(s.kinetic(after), s.kinetic(s.v));
}

TEST(RollingResistance, ALargeBudgetStopsTheSpinAndNoMore) {
  const TwoSpinningTets s(Vec3(3.0, -1.0, 2.0), Vec3::Zero());
  const SpinBody body = s.body();
  const RollingContact contact{{0, 0}, {kStatic, 0}, 1e6};
  const Matrix3Xd after = s.v + resist_rolling({&body, 1}, {&contact, 1})[0];
  EXPECT_LT(s.angular(after, 0).norm(), 1e-12 * s.angular(s.v, 0).norm());
  // What is left is the drift: every node of the fragment moves with its centre.
  for (Index n = 0; n < 4; ++n) EXPECT_LT((after.col(n) - Vec3(0.3, -0.1, 0.2)).norm(), 1e-12);
}

TEST(RollingResistance, BetweenTwoFragmentsKeepsAngularMomentumAndNeverAddsEnergy) {
  const TwoSpinningTets s(Vec3(3.0, -1.0, 2.0), Vec3(-1.0, 4.0, 0.5));
  const SpinBody body = s.body();
  const Vec3 total_before = s.angular(s.v, 0) + s.angular(s.v, 1);
  for (const double budget : {1e-3, 0.1, 1.0, 1e6}) {
    const RollingContact contact{{0, 0}, {0, 1}, budget};
    const Matrix3Xd after = s.v + resist_rolling({&body, 1}, {&contact, 1})[0];
    // The centres do not move relative to each other (the momenta are kept), so the
    // couple keeps the total about any point.
    EXPECT_LT((s.angular(after, 0) + s.angular(after, 1) - total_before).norm(), 1e-12) << budget;
    EXPECT_LT((s.angular(after, 0) - s.angular(s.v, 0)).norm(), budget + 1e-12) << budget;
    for (Index f = 0; f < 2; ++f) EXPECT_LT((s.momentum(after, f) - s.momentum(s.v, f)).norm(), 1e-12) << budget;
    EXPECT_LE(s.kinetic(after), s.kinetic(s.v)) << budget;
  }
}

TEST(RollingResistance, AnUnlimitedBudgetGivesTwoFragmentsOneSpin) {
  const TwoSpinningTets s(Vec3(3.0, -1.0, 2.0), Vec3(-1.0, 4.0, 0.5));
  const SpinBody body = s.body();
  const RollingContact contact{{0, 0}, {0, 1}, 1e6};
  const std::vector<Matrix3Xd> change = resist_rolling({&body, 1}, {&contact, 1});
  const Matrix3Xd after = s.v + change[0];
  // Each fragment is now a rigid spin about its centre (its nodes' relative velocities
  // are ω × r), with one ω for both: recover it from two node pairs of each.
  const auto spin_of = [&](Index first) {
    // v_i − v_j = ω × (x_i − x_j) for three edges from node `first`: solve for ω.
    Mat3 a;
    Vec3 b;
    Eigen::Matrix<double, 9, 3> lhs;
    Eigen::Matrix<double, 9, 1> rhs;
    for (int e = 0; e < 3; ++e) {
      const Vec3 d = s.x.col(first + e + 1) - s.x.col(first);
      a << 0, d.z(), -d.y(), -d.z(), 0, d.x(), d.y(), -d.x(), 0;  // ω × d = a ω
      b = after.col(first + e + 1) - after.col(first);
      lhs.block<3, 3>(3 * e, 0) = a;
      rhs.segment<3>(3 * e) = b;
    }
    return Vec3(lhs.colPivHouseholderQr().solve(rhs));
  };
  EXPECT_LT((spin_of(0) - spin_of(4)).norm(), 1e-10);
}

TEST(RollingResistance, APinnedFragmentCountsAsStillAndIsNotMoved) {
  TwoSpinningTets s(Vec3(3.0, -1.0, 2.0), Vec3(-1.0, 4.0, 0.5));
  s.pinned[5] = 1;
  const SpinBody body = s.body();
  const RollingContact contact{{0, 0}, {0, 1}, 1e6};
  const Matrix3Xd change = resist_rolling({&body, 1}, {&contact, 1})[0];
  for (Index n = 4; n < 8; ++n) EXPECT_EQ(change.col(n), Vec3::Zero());
  // Against a still side, the free fragment stops spinning.
  EXPECT_LT(s.angular(s.v + change, 0).norm(), 1e-12 * s.angular(s.v, 0).norm());
}

/// A regular tet of edge 2 cm standing in for a chip, its one sphere (inscribed, at the
/// centroid) resting on the ground, spinning at 20 rad/s about a horizontal axis.
struct SpinningChip {
  double rolling_resistance = 0;
  std::unique_ptr<World> world;
  double mass = 0, inertia = 0, radius = 0;
  static constexpr double kSpin = 20.0;
  explicit SpinningChip(double mu) : rolling_resistance(mu) {
    const double a = 0.02;
    radius = a / (2.0 * std::sqrt(6.0));
    Matrix3Xd x(3, 4);
    x << 1, -1, -1, 1,  //
        1, -1, 1, -1,   //
        1, 1, -1, -1;
    x *= a / (2.0 * std::sqrt(2.0));  // a regular tet of edge a about the origin
    x.row(2).array() += radius;       // its inscribed sphere touches z = 0
    if ((x.col(1) - x.col(0)).cross(x.col(2) - x.col(0)).dot(x.col(3) - x.col(0)) < 0) x.col(2).swap(x.col(3));
    testing::SceneParts s;
    BodyDescription chip;
    chip.name = "chip";
    chip.rest = x;
    chip.tets = Matrix4Xu(4, 1);
    chip.tets << 0, 1, 2, 3;
    chip.material = Material{.density = 1000, .youngs_modulus = 1e6, .poisson_ratio = 0.3};
    chip.contact.rolling_resistance = mu;
    chip.spheres.tet = {0};
    chip.spheres.barycentric = {Vec4::Constant(0.25)};
    chip.spheres.radius = {radius};
    const Vec3 centre = x.rowwise().mean();
    chip.velocity = Matrix3Xd(3, 4);
    for (int n = 0; n < 4; ++n) chip.velocity.col(n) = Vec3(kSpin, 0, 0).cross(x.col(n) - centre);
    s.bodies.push_back(chip);
    s.environment.ground = Plane{};
    s.environment.ground->material.rolling_resistance = mu;
    world = s.make();
    const ImplicitIntegrator& body = world->bodies()[0].integrator();
    for (int n = 0; n < 4; ++n) {
      mass += body.node_masses()[n];
      inertia += body.node_masses()[n] * (x.col(n) - centre).tail<2>().squaredNorm();  // about the x axis
    }
  }
  /// The spin about x [rad/s], from the nodes' angular momentum about their centre.
  [[nodiscard]] double spin() const {
    const ImplicitIntegrator& body = world->bodies()[0].integrator();
    const Vec3 centre = body.positions().rowwise().mean();  // equal node masses
    Vec3 l = Vec3::Zero();
    for (int n = 0; n < 4; ++n) {
      l += body.node_masses()[n] * (body.positions().col(n) - centre).cross(body.velocities().col(n));
    }
    return l.x() / inertia;
  }
  /// When resistance μ_r r m g stops the spin I ω₀ [s].
  [[nodiscard]] double stopping_time() const { return inertia * kSpin / (rolling_resistance * radius * mass * 9.81); }
};

// Session 29's finding: a one-tet fragment's sphere spun in place on the ground for
// seconds, its centre at rest, because friction weighs the centre. With rolling
// resistance the spin decays at the rate μ_r r m g / I (half gone at half the stopping
// time, within 10 % of the start) and stops; without it, it stays.
TEST(RollingResistance, AChipSpinningOnTheGroundStopsAtTheRateItsResistanceSets) {
  SpinningChip chip(0.1);
  const double stop = chip.stopping_time();
  ASSERT_GT(stop, 0.2);  // the test's premise: many steps of 1/240 s
  const int half = static_cast<int>(std::lround(0.5 * stop * 240.0));
  for (int i = 0; i < half; ++i) ASSERT_TRUE(chip.world->step().status.ok());
  std::printf("chip: stopping time %.3f s, spin at half of it %.3f rad/s\n", stop, chip.spin());
  EXPECT_NEAR(chip.spin(), 0.5 * SpinningChip::kSpin, 0.1 * SpinningChip::kSpin);
  for (int i = half; i < 3 * half; ++i) ASSERT_TRUE(chip.world->step().status.ok());
  EXPECT_LT(std::abs(chip.spin()), 0.02 * SpinningChip::kSpin);
  EXPECT_LT(chip.world->sphere_penetration(), 0.1 * chip.radius);

  SpinningChip free_spinner(0.0);
  for (int i = 0; i < 3 * half; ++i) ASSERT_TRUE(free_spinner.world->step().status.ok());
  std::printf("chip: spin %.3f rad/s after 3/2 of it, %.3f rad/s without resistance\n", chip.spin(), free_spinner.spin());
  EXPECT_GT(free_spinner.spin(), 0.9 * SpinningChip::kSpin);
}

}  // namespace
}  // namespace fissure::sim
