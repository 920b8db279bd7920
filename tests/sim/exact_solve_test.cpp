// ImplicitIntegrator::solve_exactly: backward Euler solved to convergence.
#include <gtest/gtest.h>

#include <cstdio>

#include "player/sim/implicit_integrator.h"
#include "player/sim/world.h"
#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"

namespace fissure::sim {
namespace {

/// A steel-stiff 0.3 m bar spinning at `spin` rad/s about its middle, with a little
/// stretch so its forces are not zero.
struct SpinningBar {
  TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(0.3, 0.1, 0.1), 3, 1, 1);
  std::unique_ptr<ImplicitIntegrator> body;

  SpinningBar(const Material& material, double spin) {
    body = std::make_unique<ImplicitIntegrator>(cage.rest_positions, cage.tets, material);
    const Vec3 centre = cage.rest_positions.rowwise().mean();
    Matrix3Xd x = cage.rest_positions, v(3, x.cols());
    for (Eigen::Index n = 0; n < x.cols(); ++n) {
      x.col(n) = centre + Vec3(1.001, 1.0, 0.999).cwiseProduct(x.col(n) - centre);
      v.col(n) = Vec3(0.0, 0.0, spin).cross(x.col(n) - centre);
    }
    body->set_positions(x);
    body->set_velocities(v);
  }

  /// One linear step of `s`, the state it started from kept in `start`.
  void step_linearly(const StepSettings& s) {
    body->save(start);
    ASSERT_EQ(body->step(s), SolveStatus::Converged);
  }
  ImplicitIntegrator::Checkpoint start;

  [[nodiscard]] double energy(const Vec3& gravity) const {
    return body->energy() - gravity.dot(body->positions() * body->node_masses());
  }
};

/// h (f(x₁) + M g − α M v₁ + β K₀ v₁) − M (v₁ − v₀), the step's equation with the forces at
/// its end, K₀ the warped stiffness at its start (the rotations at x₀).
Matrix3Xd step_residual(const ImplicitIntegrator& body, const ImplicitIntegrator::Checkpoint& start,
                        const StepSettings& s) {
  const CorotatedElasticity& elasticity = body.elasticity();
  const Material& m = body.material();
  std::vector<Mat3> rotations;
  elasticity.rotations(body.positions(), rotations);
  Matrix3Xd r = Matrix3Xd::Zero(3, body.node_count());
  elasticity.add_forces(body.positions(), rotations, r);
  std::vector<Mat3> start_rotations;
  elasticity.rotations(start.positions, start_rotations);
  for (TetIndex t = 0; t < elasticity.tet_count(); ++t) {
    Eigen::Matrix<double, 12, 1> v;
    for (int j = 0; j < 4; ++j) v.segment<3>(3 * j) = body.velocities().col(elasticity.tets()(j, t));
    const Eigen::Matrix<double, 12, 1> kv = elasticity.stiffness(t, start_rotations[t]) * v;
    for (int j = 0; j < 4; ++j) r.col(elasticity.tets()(j, t)) += m.rayleigh_stiffness * kv.segment<3>(3 * j);
  }
  for (Eigen::Index n = 0; n < r.cols(); ++n) {
    const double mass = body.node_masses()[n];
    const Vec3 v = body.velocities().col(n);
    r.col(n) = s.dt * (r.col(n) + mass * (s.gravity - m.rayleigh_mass * v)) - mass * (v - start.velocities.col(n));
  }
  return r;
}

TEST(ExactSolve, ConvergedAnswerSolvesTheStepWithTheForcesAtItsEnd) {
  const Material material{.density = 7800, .youngs_modulus = 1e9, .poisson_ratio = 0.3, .rayleigh_mass = 0.5,
                          .rayleigh_stiffness = 1e-4};
  SpinningBar bar(material, 10.0);
  StepSettings s;
  s.dt = 0.05;  // the bar turns 0.5 rad in a step
  ASSERT_NO_FATAL_FAILURE(bar.step_linearly(s));
  ImplicitIntegrator& body = *bar.body;
  const ImplicitIntegrator::Checkpoint& start = bar.start;
  const double linear_residual = step_residual(body, start, s).cwiseAbs().maxCoeff();
  const ImplicitIntegrator::ExactSolve exact = body.solve_exactly(s, start, 50);
  ASSERT_TRUE(exact.converged);
  ASSERT_EQ(exact.status, SolveStatus::Converged);
  const double residual = step_residual(body, start, s).cwiseAbs().maxCoeff();
  // The momentum scale of the step: a node's mass times its speed.
  const double momentum = body.node_masses().maxCoeff() * start.velocities.colwise().norm().maxCoeff();
  std::printf("step residual: linear %.3g, exact %.3g after %d iterations (momentum scale %.3g)\n", linear_residual,
              residual, exact.iterations, momentum);
  EXPECT_GT(linear_residual, 1e3 * momentum);  // the linear step is far from the equation here
  // Newton stops on the energy (the decrement), not on this residual: in impulse units it
  // is dominated by the stiff modes, where an impulse moves the nodes by next to
  // nothing (h² k ≈ 1e6 kg here). Measured: 4.9e4 → 0.012.
  EXPECT_LE(residual, 1e-5 * linear_residual);
}

TEST(ExactSolve, NewtonStepsTakeTheDampingAtTheStepsStart) {
  // E's damping term is −½ h β vᵀ K₀ v with the stiffness at the step's start, which the
  // system assembled from each iteration's own stiffness does not have: its steps fell
  // short by the same share every iteration (linear convergence, a factorization each).
  // Here h β = h², so that share is large where the bar has turned within the step.
  // Measured: 49 iterations with A's steps alone, 12 with them taken to ∇²E's; those
  // 12 factor A twice (the first iteration's factor preconditions the next ones).
  const Material material{.density = 7800, .youngs_modulus = 1e9, .poisson_ratio = 0.3, .rayleigh_stiffness = 0.05};
  SpinningBar bar(material, 10.0);
  StepSettings s;
  s.dt = 0.05;
  ASSERT_NO_FATAL_FAILURE(bar.step_linearly(s));
  ImplicitIntegrator& body = *bar.body;
  const ImplicitIntegrator::Checkpoint& start = bar.start;
  const double linear_residual = step_residual(body, start, s).cwiseAbs().maxCoeff();
  const ImplicitIntegrator::ExactSolve exact = body.solve_exactly(s, start, 50);
  std::printf("Newton iterations with h β = h²: %d, %d factorizations\n", exact.iterations, exact.factorizations);
  ASSERT_TRUE(exact.converged);
  EXPECT_LE(exact.iterations, 15);
  EXPECT_LE(exact.factorizations, 3);
  EXPECT_LE(step_residual(body, start, s).cwiseAbs().maxCoeff(), 1e-5 * linear_residual);
}

TEST(ExactSolve, NewtonStartsFromTheLowerOfTheLinearAnswerAndTheInertialGuess) {
  // The guard solves again where solve()'s answer gained energy, and that answer may be
  // far off; Newton then starts from x₀ + h v₀ if E is lower there. Where it starts must
  // not change where it ends.
  const Material material{.density = 7800, .youngs_modulus = 1e9, .poisson_ratio = 0.3, .rayleigh_mass = 0.5,
                          .rayleigh_stiffness = 1e-4};
  StepSettings s;
  s.dt = 0.05;
  SpinningBar from_linear(material, 10.0), from_inertial(material, 10.0);
  ASSERT_NO_FATAL_FAILURE(from_linear.step_linearly(s));
  ASSERT_NO_FATAL_FAILURE(from_inertial.step_linearly(s));
  // The second bar's linear answer spoiled: every coordinate up to 3 cm off (the bar is 10 cm thick).
  const Matrix3Xd spoiled = testing::perturbed(from_inertial.body->positions(), 0.03, 7);
  from_inertial.body->set_positions(spoiled);
  const double linear_residual = step_residual(*from_linear.body, from_linear.start, s).cwiseAbs().maxCoeff();
  const ImplicitIntegrator::ExactSolve a = from_linear.body->solve_exactly(s, from_linear.start, 50);
  const ImplicitIntegrator::ExactSolve b = from_inertial.body->solve_exactly(s, from_inertial.start, 50);
  const double apart = (from_linear.body->positions() - from_inertial.body->positions()).cwiseAbs().maxCoeff();
  std::printf("from the linear answer: %d iterations; from the inertial guess: %d; answers %.3g m apart\n",
              a.iterations, b.iterations, apart);
  ASSERT_TRUE(a.converged && b.converged);
  EXPECT_FALSE(a.from_inertial_guess);  // the warped step turns the bar; x₀ + h v₀ stretches it 14 %
  EXPECT_TRUE(b.from_inertial_guess);
  // Both stop on the same decrement, not at the same bits: the nodes of a bar whose ends
  // move 7.5 cm in the step agree to 2.3 µm (measured).
  EXPECT_LE(apart, 1e-5);
  EXPECT_LE(step_residual(*from_inertial.body, from_inertial.start, s).cwiseAbs().maxCoeff(), 1e-5 * linear_residual);
}

TEST(ExactSolve, AStiffBarTurningFastGainsNoEnergy) {
  // Moved on lines, each node of a body turning hω = 0.5 rad in a step ends
  // √(1 + (hω)²) as far out: strain the linear step does not see, paid for in energy.
  const Material material{.density = 7800, .youngs_modulus = 1e11, .poisson_ratio = 0.3};
  StepSettings s;
  s.dt = 0.05;
  for (const bool exactly : {false, true}) {
    SpinningBar bar(material, 10.0);
    ImplicitIntegrator& body = *bar.body;
    const double initial = bar.energy(s.gravity);
    double peak = initial;
    int iterations = 0;
    for (int i = 0; i < 20; ++i) {
      ImplicitIntegrator::Checkpoint start;
      body.save(start);
      ASSERT_EQ(body.step(s), SolveStatus::Converged);
      if (exactly) iterations += body.solve_exactly(s, start, 50).iterations;
      peak = std::max(peak, bar.energy(s.gravity));
    }
    std::printf("%s: %.4g J → peak %.4g J (×%.3g)%s\n", exactly ? "exact" : "linear", initial, peak, peak / initial,
                exactly ? (", " + std::to_string(iterations) + " Newton iterations in 20 steps").c_str() : "");
    if (exactly) {
      EXPECT_LE(peak, initial * (1.0 + 1e-9));
    } else {
      EXPECT_GT(peak, 10.0 * initial);  // the failure the exact solve is for
    }
  }
}

/// The spinning bar as a one-body scene at dt = 0.05 s with the arcs off, so nothing but
/// an exact re-solve takes its line strain away.
testing::SceneParts spinning_bar_scene(const Material& material) {
  SpinningBar bar(material, 10.0);
  testing::SceneParts scene;
  scene.bodies.push_back(testing::describe("bar", bar.cage, material));
  scene.bodies[0].positions = bar.body->positions();
  scene.bodies[0].velocity = bar.body->velocities();
  scene.settings.step.dt = 0.05;
  scene.settings.rotate_on_arcs = false;
  return scene;
}

// The world solves a substep again exactly where its linear solve gains. With the arcs
// off, nothing else takes the spinning bar's line strain away, so the linear steps gain
// without bound and the exact ones keep the start's energy.
TEST(ExactSolve, TheWorldSolvesAgainWhereTheLinearSolveGains) {
  const Material material{.density = 7800, .youngs_modulus = 1e11, .poisson_ratio = 0.3};
  for (const bool exactly : {false, true}) {
    testing::SceneParts scene = spinning_bar_scene(material);
    scene.settings.exact_when_gaining = exactly ? ExactResolve::Solve : ExactResolve::Never;
    scene.settings.energy_halvings = 0;  // what the exact re-solve does alone
    const auto world = scene.make();
    const double start = world->total_energy();
    double peak = start;
    int exact_substeps = 0, iterations = 0;
    for (int i = 0; i < 20; ++i) {
      const StepReport report = world->step();
      ASSERT_TRUE(report.status.ok());
      exact_substeps += report.exact_substeps;
      iterations += report.exact_iterations;
      peak = std::max(peak, world->total_energy());
    }
    std::printf("world, %s: peak ×%.3g of the start; %d exact substeps, %d Newton iterations\n",
                exactly ? "exact where gaining" : "linear", peak / start, exact_substeps, iterations);
    if (exactly) {
      EXPECT_GT(exact_substeps, 0);
      EXPECT_LE(peak, start * (1.0 + 1e-9));
    } else {
      EXPECT_EQ(exact_substeps, 0);
      EXPECT_GT(peak, 10.0 * start);
    }
  }
}

// exact_gain_share lets a substep spend a share of what the run has dissipated so far
// instead of solving again. With nothing dissipated (the undamped spinning bar) every
// gain is still solved again; with damping, gains within the share are let through and
// the run's bound still holds (the halvings keep it).
TEST(ExactSolve, AGainWithinTheShareOfWhatTheRunDissipatedIsNotSolvedAgain) {
  const auto run = [](double damping, double share, int halvings) {
    const Material material{
        .density = 7800, .youngs_modulus = 1e11, .poisson_ratio = 0.3, .rayleigh_mass = damping};
    testing::SceneParts scene = spinning_bar_scene(material);
    scene.settings.exact_gain_share = share;
    scene.settings.energy_halvings = halvings;
    const auto world = scene.make();
    const double start = world->total_energy();
    double peak = start;
    int exact_substeps = 0;
    for (int i = 0; i < 20; ++i) {
      const StepReport report = world->step();
      EXPECT_TRUE(report.status.ok());
      exact_substeps += report.exact_substeps;
      peak = std::max(peak, world->total_energy());
    }
    std::printf("damping %g, share %g: peak ×%.9g of the start, %d exact substeps\n", damping, share, peak / start,
                exact_substeps);
    return std::pair{peak / start, exact_substeps};
  };
  const auto [undamped_peak, undamped_exact] = run(0.0, 1.0, 0);
  EXPECT_GT(undamped_exact, 0);
  EXPECT_LE(undamped_peak, 1.0 + 1e-9);
  const auto [strict_peak, strict_exact] = run(10.0, 0.0, 6);
  const auto [shared_peak, shared_exact] = run(10.0, 1.0, 6);
  EXPECT_GT(strict_exact, 0);
  EXPECT_LT(shared_exact, strict_exact);
  EXPECT_LE(strict_peak, 1.0 + 1e-9);
  EXPECT_LE(shared_peak, 1.0 + 1e-9);
}

}  // namespace
}  // namespace fissure::sim
