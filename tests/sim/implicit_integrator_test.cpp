#include "player/sim/implicit_integrator.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <initializer_list>
#include <random>
#include <vector>

#include "player/sim/lanes.h"
#include "tests/support/procedural.h"

namespace fissure::sim {
namespace {

Vec3 linear_momentum(const ImplicitIntegrator& body) {
  return body.velocities() * body.node_masses();
}

Vec3 angular_momentum(const ImplicitIntegrator& body) {
  Vec3 l = Vec3::Zero();
  for (Eigen::Index n = 0; n < body.positions().cols(); ++n) {
    l += body.node_masses()[n] * body.positions().col(n).cross(body.velocities().col(n));
  }
  return l;
}

TEST(ImplicitIntegrator, FreeFlightConservesMomentum) {
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(2.0, 0.5, 0.5), 4, 1, 1);
  ImplicitIntegrator body(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e5});
  // A translation, a spin about the centre, and some deformation.
  const Vec3 centre = cage.rest_positions.rowwise().mean();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  Matrix3Xd v(3, body.node_count());
  for (Eigen::Index n = 0; n < body.positions().cols(); ++n) {
    v.col(n) = Vec3(0.3, -0.1, 0.2) + Vec3(0, 0, 2.0).cross(body.positions().col(n) - centre) + Vec3(u(rng), u(rng), u(rng));
  }
  body.set_velocities(v);
  const Vec3 p0 = linear_momentum(body);
  const Vec3 l0 = angular_momentum(body);
  StepSettings settings;
  settings.gravity.setZero();
  settings.dt = 1e-3;
  for (int i = 0; i < 200; ++i) ASSERT_EQ(body.step(settings), SolveStatus::Converged);
  EXPECT_LT((linear_momentum(body) - p0).norm(), 1e-9 * p0.norm());
  // Backward Euler with a linearized stiffness conserves angular momentum only
  // approximately; state the drift over 0.2 s of spinning at 2 rad/s.
  EXPECT_LT((angular_momentum(body) - l0).norm(), 2e-2 * l0.norm());
}

TEST(ImplicitIntegrator, EnergyNeverIncreasesWithoutExternalForces) {
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(2.0, 0.5, 0.5), 4, 1, 1);
  ImplicitIntegrator body(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e5});
  Matrix3Xd stretched = cage.rest_positions;
  stretched.row(0) *= 1.2;  // along x
  body.set_positions(stretched);
  StepSettings settings;
  settings.gravity.setZero();
  settings.dt = 1.0 / 120.0;
  double previous = body.energy();
  for (int i = 0; i < 300; ++i) {
    ASSERT_EQ(body.step(settings), SolveStatus::Converged);
    const double now = body.energy();
    EXPECT_LE(now, previous * (1.0 + 1e-9) + 1e-12) << "step " << i;
    previous = now;
  }
}

/// Clamps each body at the cage's x = 0 face (a cantilever).
void pin_at_x0(const TetMesh& cage, std::initializer_list<ImplicitIntegrator*> bodies) {
  for (Index n = 0; n < cage.node_count(); ++n) {
    if (cage.rest_positions(0, n) != 0.0) continue;
    for (ImplicitIntegrator* body : bodies) body->pin(n);
  }
}

TEST(ImplicitIntegrator, DirectAndBothConjugateGradientPreconditionersAgree) {
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(2.0, 0.5, 0.5), 4, 2, 2);
  for (const StiffnessModel model : {StiffnessModel::Warped, StiffnessModel::Exact}) {
    ImplicitIntegrator direct(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e6});
    ImplicitIntegrator jacobi(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e6});
    ImplicitIntegrator lagged(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e6});
    pin_at_x0(cage, {&direct, &jacobi, &lagged});
    StepSettings settings;
    settings.stiffness = model;
    StepSettings cg_jacobi = settings;
    cg_jacobi.solver = LinearSolver::ConjugateGradient;
    cg_jacobi.preconditioner = Preconditioner::Jacobi;
    cg_jacobi.tolerance = 1e-12;
    StepSettings cg_lagged = cg_jacobi;
    cg_lagged.preconditioner = Preconditioner::LaggedCholesky;
    for (int i = 0; i < 20; ++i) {
      ASSERT_EQ(direct.step(settings), SolveStatus::Converged);
      ASSERT_EQ(jacobi.step(cg_jacobi), SolveStatus::Converged);
      ASSERT_EQ(lagged.step(cg_lagged), SolveStatus::Converged);
    }
    EXPECT_LT((direct.positions() - jacobi.positions()).norm(), 1e-8 * direct.positions().norm());
    EXPECT_LT((direct.positions() - lagged.positions()).norm(), 1e-8 * direct.positions().norm());
    EXPECT_EQ(direct.factorizations(), 20);
    EXPECT_EQ(jacobi.factorizations(), 0);
    EXPECT_GE(lagged.factorizations(), 1);
    // The cantilever sags under gravity, and its pinned end stays put.
    EXPECT_LT(direct.positions().row(2).minCoeff(), -1e-4);
    for (Index n = 0; n < cage.node_count(); ++n) {
      if (cage.rest_positions(0, n) == 0.0) {
        EXPECT_EQ(direct.positions().col(n), cage.rest_positions.col(n));
      }
    }
  }
}

TEST(ImplicitIntegrator, ExtrapolatedWarmStartSavesIterationsOnASmoothMotionOnly) {
  // A sagging cantilever moves smoothly, so 2 Δv_last − Δv_previous predicts the next Δv
  // better than Δv_last. A contact correction (here a zero one: correct_velocities says
  // "a contact acted") turns the extrapolation off for the next two solves.
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(2.0, 0.5, 0.5), 8, 2, 2);
  StepSettings settings;
  settings.solver = LinearSolver::ConjugateGradient;
  settings.preconditioner = Preconditioner::LaggedCholesky;
  settings.tolerance = 1e-4;
  ImplicitIntegrator smooth(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e6});
  ImplicitIntegrator corrected(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e6});
  pin_at_x0(cage, {&smooth, &corrected});
  int smooth_iterations = 0, corrected_iterations = 0;
  for (int i = 0; i < 60; ++i) {
    ASSERT_EQ(smooth.step(settings), SolveStatus::Converged);
    ASSERT_EQ(corrected.step(settings), SolveStatus::Converged);
    corrected.correct_velocities(Eigen::VectorXd::Zero(corrected.system_size()), settings.dt);
    smooth_iterations += smooth.last_iterations();
    corrected_iterations += corrected.last_iterations();
  }
  std::printf("iterations over 60 steps: %d extrapolated, %d from the last Δv\n", smooth_iterations,
              corrected_iterations);
  EXPECT_LE(smooth_iterations, 0.75 * corrected_iterations);
  // Both solve to the same tolerance: the same motion, to well within what it sags.
  const double sag = -corrected.positions().row(2).minCoeff();
  EXPECT_GT(sag, 1e-3);
  EXPECT_LT((smooth.positions() - corrected.positions()).cwiseAbs().maxCoeff(), 1e-2 * sag);
}

TEST(ImplicitIntegrator, LaggedCholeskyFollowsARigidRotationWithoutRefactoring) {
  // A warped system after a rigid rotation R is exactly R A_f Rᵀ, so the rotated old
  // factor is the exact inverse: conjugate gradients converge as fast as unrotated and
  // nothing is refactored, however large the rotation. (A large factor is kept in single
  // precision, where one iteration gets ~1e-7 and this test's 1e-10 takes a second.)
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(2.0, 0.5, 0.5), 6, 2, 2);
  StepSettings settings;
  settings.solver = LinearSolver::ConjugateGradient;
  settings.preconditioner = Preconditioner::LaggedCholesky;
  settings.gravity = Vec3(0.0, 0.0, -9.81);
  settings.tolerance = 1e-10;
  // Stretch it a little, factor at that state, then take the same state turned by R:
  // the system is R A_f Rᵀ exactly.
  for (const double angle : {0.3, 1.5, 3.0}) {
    ImplicitIntegrator body(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e7});
    Matrix3Xd stretched = cage.rest_positions;
    stretched.row(0) *= 1.01;
    body.set_positions(stretched);
    ASSERT_EQ(body.step(settings), SolveStatus::Converged);
    ASSERT_EQ(body.factorizations(), 1);
    const int unrotated_iterations = body.last_iterations();
    const Mat3 rotation = Eigen::AngleAxisd(angle, Vec3(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
    body.set_positions(rotation * stretched);
    body.set_velocities(Matrix3Xd::Zero(3, body.node_count()));
    ASSERT_EQ(body.step(settings), SolveStatus::Converged);
    EXPECT_EQ(body.factorizations(), 1) << "angle " << angle;
    EXPECT_EQ(body.last_iterations(), unrotated_iterations) << "angle " << angle;
    EXPECT_LE(body.last_iterations(), 2) << "angle " << angle;
  }
}

// A lagged factor that no longer fits the system (nearly incompressible, factored at
// rest, then twisted along its length: no rotation per node undoes that) is remade
// within the solve once conjugate gradients have run 4 × refactor_iterations, and the
// solve goes on from there to the direct solver's answer. Without that rule (a
// refactor_iterations so large the cap is the solve's own) the same solve runs on with
// the old factor.
TEST(ImplicitIntegrator, AStaleLaggedFactorIsRemadeWithinTheSolve) {
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(2.0, 0.5, 0.5), 6, 2, 2);
  const Material rubber{.youngs_modulus = 1e6, .poisson_ratio = 0.4999};
  Matrix3Xd twisted = cage.rest_positions;
  for (Index n = 0; n < cage.node_count(); ++n) {
    const double angle = 0.6 * cage.rest_positions(0, n);
    twisted.col(n) = Eigen::AngleAxisd(angle, Vec3::UnitX()) * Vec3(cage.rest_positions.col(n));
  }
  StepSettings lagged;
  lagged.solver = LinearSolver::ConjugateGradient;
  lagged.preconditioner = Preconditioner::LaggedCholesky;
  lagged.tolerance = 1e-10;
  lagged.refactor_iterations = 2;
  const auto twisted_step = [&](ImplicitIntegrator& body, const StepSettings& settings) {
    EXPECT_TRUE(body.prepare(settings));  // factored at rest
    body.set_positions(twisted);
    EXPECT_EQ(body.step(settings), SolveStatus::Converged);
  };
  ImplicitIntegrator remade(cage.rest_positions, cage.tets, rubber);
  twisted_step(remade, lagged);
  EXPECT_EQ(remade.factorizations(), 2);
  EXPECT_GT(remade.last_iterations(), 4 * lagged.refactor_iterations);      // ran to the cap on the old factor,
  EXPECT_LE(remade.last_iterations(), 4 * lagged.refactor_iterations + 2);  // then converged on the new one

  StepSettings never = lagged;
  never.refactor_iterations = lagged.max_iterations;
  ImplicitIntegrator kept(cage.rest_positions, cage.tets, rubber);
  twisted_step(kept, never);
  EXPECT_EQ(kept.factorizations(), 1);
  EXPECT_GT(kept.last_iterations(), 4 * lagged.refactor_iterations + 2);
  std::printf("twisted solve: %d iterations on the factor made at rest, %d with it remade after %d\n",
              kept.last_iterations(), remade.last_iterations(), 4 * lagged.refactor_iterations);

  ImplicitIntegrator direct(cage.rest_positions, cage.tets, rubber);
  direct.set_positions(twisted);
  ASSERT_EQ(direct.step(StepSettings{}), SolveStatus::Converged);
  const double moved = (direct.positions() - twisted).norm();
  EXPECT_GT(moved, 0.0);
  EXPECT_LT((remade.positions() - direct.positions()).norm(), 1e-6 * moved);
  EXPECT_LT((kept.positions() - direct.positions()).norm(), 1e-6 * moved);
}

// prepare() does the first solve's factorization ahead: the first step then factors
// nothing and lands on exactly the state (bit for bit) of a body that factored in it.
TEST(ImplicitIntegrator, PrepareFactorsAheadAndTheFirstStepAnswersTheSame) {
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(2.0, 0.5, 0.5), 6, 2, 2);
  StepSettings settings;
  settings.solver = LinearSolver::ConjugateGradient;
  settings.preconditioner = Preconditioner::LaggedCholesky;
  settings.tolerance = 1e-6;
  ImplicitIntegrator prepared(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e6});
  ImplicitIntegrator plain(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e6});
  pin_at_x0(cage, {&prepared, &plain});
  ASSERT_TRUE(prepared.prepare(settings));
  EXPECT_EQ(prepared.factorizations(), 1);
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(prepared.step(settings), SolveStatus::Converged);
    ASSERT_EQ(plain.step(settings), SolveStatus::Converged);
  }
  EXPECT_EQ(prepared.factorizations(), 1);  // none in the steps
  EXPECT_EQ(plain.factorizations(), 1);
  EXPECT_TRUE(prepared.positions() == plain.positions());
  EXPECT_TRUE(prepared.velocities() == plain.velocities());
  EXPECT_GT(plain.positions().row(2).cwiseAbs().maxCoeff(), 0.0);  // it moved
  // Other solvers have nothing to do ahead.
  settings.solver = LinearSolver::Direct;
  ImplicitIntegrator direct(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e6});
  EXPECT_TRUE(direct.prepare(settings));
  EXPECT_EQ(direct.factorizations(), 0);
}

TEST(ImplicitIntegrator, StableAtLargeStepsAndExtremeMaterials) {
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(1.0, 0.25, 0.25), 4, 1, 1);
  for (const double youngs : {1e3, 1e11}) {
    for (const double nu : {0.0, 0.499}) {
      for (const double dt : {1e-5, 0.1}) {
        ImplicitIntegrator body(cage.rest_positions, cage.tets, Material{.youngs_modulus = youngs, .poisson_ratio = nu});
        body.pin(0);
        body.set_velocities(Matrix3Xd::Constant(3, body.node_count(), 5.0));  // pinned node 0 stays at rest
        StepSettings settings;
        settings.dt = dt;
        for (int i = 0; i < 20; ++i) {
          const SolveStatus status = body.step(settings);
          ASSERT_TRUE(status == SolveStatus::Converged) << "E " << youngs << " nu " << nu << " dt " << dt;
        }
        EXPECT_TRUE(body.positions().allFinite());
        EXPECT_LT(body.energy(), 1e12) << "E " << youngs << " nu " << nu << " dt " << dt;
      }
    }
  }
}

}  // namespace
}  // namespace fissure::sim

namespace fissure::sim {
namespace {

/// Static tip deflection of a clamped beam under its own weight, reached by implicit
/// steps so large that backward Euler becomes a Newton iteration on the statics.
double cantilever_tip_deflection(int along, int across) {
  const double length = 4.0, side = 0.25;
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(length, side, side), along, across, across);
  ImplicitIntegrator beam(cage.rest_positions, cage.tets, Material{.density = 1000, .youngs_modulus = 1e9, .poisson_ratio = 0.3});
  pin_at_x0(cage, {&beam});
  StepSettings settings;
  settings.dt = 10.0;
  for (int i = 0; i < 40; ++i) {
    if (beam.step(settings) != SolveStatus::Converged) return std::numeric_limits<double>::quiet_NaN();
    beam.set_velocities(Matrix3Xd::Zero(3, beam.node_count()));  // keep only the displacement: statics
  }
  double tip = 0.0;
  int count = 0;
  for (Index n = 0; n < cage.node_count(); ++n) {
    if (cage.rest_positions(0, n) == length) {
      tip += beam.positions()(2, n) - cage.rest_positions(2, n);
      ++count;
    }
  }
  return -tip / count;
}

TEST(ImplicitIntegrator, CantileverDeflectionConvergesTowardEulerBernoulli) {
  // w = q L⁴ / (8 E I), q = ρ g A, I = side⁴ / 12.
  const double side = 0.25, q = 1000 * 9.81 * side * side, inertia = std::pow(side, 4) / 12.0;
  const double expected = q * std::pow(4.0, 4) / (8.0 * 1e9 * inertia);
  double previous_error = 1.0;
  for (const auto& [along, across] : {std::pair{8, 1}, std::pair{16, 2}, std::pair{32, 4}}) {
    const double w = cantilever_tip_deflection(along, across);
    const double error = std::abs(w - expected) / expected;
    std::printf("cantilever %d×%d×%d: tip %.5g m, Euler–Bernoulli %.5g m, relative error %.3f\n", along, across, across, w,
                expected, error);
    EXPECT_LT(error, previous_error);
    previous_error = error;
  }
  EXPECT_LT(previous_error, 0.35);  // linear tets lock in bending; the error shrinks with refinement
}

}  // namespace
}  // namespace fissure::sim

namespace fissure::sim {
namespace {

/// FNV-1a over the bytes of the state: any difference in any bit changes it.
std::uint64_t state_hash(const ImplicitIntegrator& body) {
  std::uint64_t hash = 1469598103934665603ull;
  for (const Matrix3Xd* m : {&body.positions(), &body.velocities()}) {
    const auto* bytes = reinterpret_cast<const unsigned char*>(m->data());
    for (std::size_t i = 0; i < static_cast<std::size_t>(m->size()) * sizeof(double); ++i) {
      hash = (hash ^ bytes[i]) * 1099511628211ull;
    }
  }
  return hash;
}

std::uint64_t hash_after_steps(LinearSolver solver) {
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(2.0, 0.5, 0.5), 8, 2, 2);
  ImplicitIntegrator body(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e6, .rayleigh_mass = 0.1});
  pin_at_x0(cage, {&body});
  StepSettings settings;
  settings.solver = solver;
  for (int i = 0; i < 50; ++i) EXPECT_EQ(body.step(settings), SolveStatus::Converged);
  return state_hash(body);
}

TEST(ImplicitIntegrator, DeterministicStateHashAfterManySteps) {
  for (const LinearSolver solver : {LinearSolver::Direct, LinearSolver::ConjugateGradient}) {
    EXPECT_EQ(hash_after_steps(solver), hash_after_steps(solver));
  }
}

/// A body large enough that its element and node loops split over the threads: small
/// bodies' loops run on the calling thread whatever the thread count (lanes.h), so the
/// world's thread-count test no longer reaches the split paths.
std::uint64_t large_body_hash(int threads) {
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(2.4, 0.6, 0.6), 12, 6, 6);
  ImplicitIntegrator body(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e6, .rayleigh_mass = 0.1});
  pin_at_x0(cage, {&body});
  for (int i = 0; i < 5; ++i) EXPECT_EQ(body.step(StepSettings{}), SolveStatus::Converged);
  (void)body.elasticity().energy(body.positions());  // the energy pass, and its F and Q kept for the next step
  EXPECT_EQ(body.step(StepSettings{}), SolveStatus::Converged);
  return state_hash(body);
}

TEST(ImplicitIntegrator, ALargeBodyStepsTheSameBitsOnOneThreadAndOnTwo) {
  // 2,592 tets and 637 nodes: the per-tet product (grain 512) and evaluation (256) and
  // the per-node gathers (64) make at least kFewestTasks tasks each.
  static_assert(kFewestTasks == 4, "the mesh below is sized for four grains of 512 tets");
  const std::uint64_t one = large_body_hash(1);
  EXPECT_EQ(large_body_hash(2), one);
  EXPECT_EQ(large_body_hash(4), one);
}

TEST(ParallelForRange, AShortLoopIsOneRangeAndALongOneCoversEveryItemOnce) {
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
  std::atomic<int> calls{0};
  parallel_for_range<int>(4 * 100 - 1, 100, [&](const tbb::blocked_range<int>& range) {
    ++calls;
    EXPECT_EQ(range.begin(), 0);
    EXPECT_EQ(range.end(), 399);
  });
  EXPECT_EQ(calls.load(), 1);
  std::vector<std::atomic<int>> seen(4000);
  parallel_for_range<int>(4000, 100, [&](const tbb::blocked_range<int>& range) {
    for (int i = range.begin(); i != range.end(); ++i) ++seen[static_cast<std::size_t>(i)];
  });
  for (const std::atomic<int>& s : seen) EXPECT_EQ(s.load(), 1);
  parallel_for_range<int>(0, 100, [&](const tbb::blocked_range<int>& range) { EXPECT_TRUE(range.empty()); });
}

}  // namespace
}  // namespace fissure::sim
