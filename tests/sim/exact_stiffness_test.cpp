#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <random>

#include "player/sim/corotated_elasticity.h"
#include "player/sim/implicit_integrator.h"
#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"
#include "tests/support/spinning_beam.h"

namespace fissure::sim {
namespace {

using testing::perturbed;
using testing::rotation;

Mat3 deformation_gradient(const CorotatedElasticity& e, const Matrix3Xd& x, TetIndex t) {
  Mat3 F = Mat3::Zero();
  for (int i = 0; i < 4; ++i) F += x.col(e.tets()(i, t)) * e.shape_gradients(t).col(i).transpose();
  return F;
}

/// The TRUE forces of `e` at x: every tet's rotation recomputed at x.
Matrix3Xd true_forces(const CorotatedElasticity& e, const Matrix3Xd& x) {
  std::vector<Mat3> q;
  e.rotations(x, q);
  Matrix3Xd f = Matrix3Xd::Zero(3, x.cols());
  e.add_forces(x, q, f);
  return f;
}

/// Central finite difference of tet t's true forces w.r.t. its 12 coordinates.
Mat12 finite_difference_stiffness(const CorotatedElasticity& single, const Matrix3Xd& x, double h) {
  Mat12 K;
  const Matrix4Xu& tets = single.tets();
  for (int j = 0; j < 4; ++j) {
    for (int a = 0; a < 3; ++a) {
      Matrix3Xd plus = x, minus = x;
      plus(a, tets(j, 0)) += h;
      minus(a, tets(j, 0)) -= h;
      const Matrix3Xd fp = true_forces(single, plus), fm = true_forces(single, minus);
      for (int i = 0; i < 4; ++i) K.block<3, 1>(3 * i, 3 * j + a) = (fp.col(tets(i, 0)) - fm.col(tets(i, 0))) / (2 * h);
    }
  }
  return K;
}

struct Fixture {
  TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(2.0, 1.0, 1.0), 2, 1, 1);
  Material material{.density = 1000, .youngs_modulus = 1e5, .poisson_ratio = 0.3};
  CorotatedElasticity elasticity{cage.rest_positions, cage.tets, material};
  [[nodiscard]] CorotatedElasticity single(TetIndex t) const {
    return {cage.rest_positions, cage.tets.col(t), material};
  }
};

TEST(ExactStiffness, UnprojectedMatchesFiniteDifferenceOfTrueForces) {
  const Fixture f;
  // Moderate deformation (strains ~±20 %) under a large rotation: the rotation's
  // derivative is what separates the exact Hessian from the warped one.
  const Matrix3Xd x = rotation(0.9, Vec3(1, -2, 0.5)) * perturbed(f.cage.rest_positions, 0.15, 11);
  double worst = 0.0, worst_warped = 0.0;
  for (TetIndex t = 0; t < f.elasticity.tet_count(); ++t) {
    const Mat3 F = deformation_gradient(f.elasticity, x, t);
    ASSERT_GT(F.determinant(), 0.3) << "tet " << t << " is too distorted for a clean check";
    const Mat12 K = f.elasticity.exact_stiffness(t, x, /*project=*/false);
    const Mat12 fd = finite_difference_stiffness(f.single(t), x, 1e-6);
    const double error = (K - fd).norm() / fd.norm();
    worst = std::max(worst, error);
    EXPECT_LT(error, 1e-5) << "tet " << t;
    // The exact stiffness is a true Hessian: symmetric even unprojected.
    EXPECT_LT((K - K.transpose()).norm(), 1e-12 * K.norm()) << "tet " << t;
    std::vector<Mat3> q;
    f.elasticity.rotations(x, q);
    worst_warped = std::max(worst_warped, (f.elasticity.stiffness(t, q[t]) - fd).norm() / fd.norm());
  }
  std::printf("exact vs FD of true forces: worst relative error %.2e (warped: %.2e)\n", worst, worst_warped);
  EXPECT_GT(worst_warped, 100 * worst);  // the check can tell the two models apart
}

TEST(ExactStiffness, UnprojectedMatchesFiniteDifferenceNearlyIncompressible) {
  Fixture f;
  f.material.poisson_ratio = 0.45;
  const CorotatedElasticity elasticity(f.cage.rest_positions, f.cage.tets, f.material);
  const Matrix3Xd x = rotation(-2.0, Vec3(0.2, 1, 0.3)) * perturbed(f.cage.rest_positions, 0.1, 12);
  for (TetIndex t = 0; t < elasticity.tet_count(); ++t) {
    const Mat12 K = elasticity.exact_stiffness(t, x, false);
    const Mat12 fd = finite_difference_stiffness(f.single(t), x, 1e-6);
    EXPECT_LT((K - fd).norm() / fd.norm(), 1e-5) << "tet " << t;
  }
}

/// Positions where every tet of `mesh` is mapped by F (about the origin).
Matrix3Xd deformed(const TetMesh& mesh, const Mat3& F) { return F * mesh.rest_positions; }

void expect_projected_semi_definite(const CorotatedElasticity& e, const Matrix3Xd& x, const char* what) {
  for (TetIndex t = 0; t < e.tet_count(); ++t) {
    const Mat12 K = e.exact_stiffness(t, x, /*project=*/true);
    ASSERT_TRUE(K.allFinite()) << what << " tet " << t;
    EXPECT_LT((K - K.transpose()).norm(), 1e-12 * K.norm()) << what << " tet " << t;
    const Eigen::SelfAdjointEigenSolver<Mat12> eigen(-K);
    const double largest = eigen.eigenvalues().cwiseAbs().maxCoeff();
    EXPECT_GE(eigen.eigenvalues().minCoeff(), -1e-9 * largest) << what << " tet " << t;
  }
}

TEST(ExactStiffness, ProjectedIsSymmetricAndNegativeSemiDefiniteEvenWhenInvertedOrCrushed) {
  for (const double nu : {0.0, 0.3, 0.49}) {
    Fixture f;
    f.material.poisson_ratio = nu;
    const CorotatedElasticity e(f.cage.rest_positions, f.cage.tets, f.material);
    expect_projected_semi_definite(e, rotation(0.9, Vec3(1, 2, 3)) * perturbed(f.cage.rest_positions, 0.3, 21), "random");
    // Heavy compression: 80 % along x, and uniformly to 30 %.
    expect_projected_semi_definite(e, deformed(f.cage, Vec3(0.2, 1.0, 1.0).asDiagonal()), "compressed x");
    expect_projected_semi_definite(e, deformed(f.cage, 0.3 * Mat3::Identity()), "compressed");
    // Squashed flat and entirely inverted (every tet mirrored), and a near-collapse onto a line.
    expect_projected_semi_definite(e, deformed(f.cage, Vec3(1.0, 1.0, 1e-9).asDiagonal()), "flat");
    expect_projected_semi_definite(e, deformed(f.cage, Vec3(1.0, 1.0, -0.5).asDiagonal()), "mirrored");
    expect_projected_semi_definite(e, deformed(f.cage, Vec3(1.0, 1e-4, -1e-4).asDiagonal()), "line");
    // One node mirrored through the plane of its opposite face: one tet inverted, its
    // neighbours heavily sheared.
    Matrix3Xd x = f.cage.rest_positions;
    const TetIndex t = 3;
    const Vec3 a = x.col(f.cage.tets(1, t)), b = x.col(f.cage.tets(2, t)), c = x.col(f.cage.tets(3, t));
    const Vec3 n = (b - a).cross(c - a).normalized();
    const NodeIndex apex = f.cage.tets(0, t);
    x.col(apex) -= 2.0 * n.dot(x.col(apex) - a) * n;
    ASSERT_LT(deformation_gradient(e, x, t).determinant(), 0.0);
    expect_projected_semi_definite(e, x, "one inverted tet");
  }
}

TEST(ExactStiffness, ProjectionChangesNothingUnderTension) {
  // Stretched (σ > 1, I₁ > 3): every twist eigenvalue is already ≥ 0, so the projected
  // and unprojected Hessians must coincide.
  const Fixture f;
  const Matrix3Xd x = rotation(0.4, Vec3(0, 1, 0)) * deformed(f.cage, Vec3(1.3, 1.1, 1.2).asDiagonal());
  for (TetIndex t = 0; t < f.elasticity.tet_count(); ++t) {
    const Mat12 projected = f.elasticity.exact_stiffness(t, x, true);
    const Mat12 raw = f.elasticity.exact_stiffness(t, x, false);
    EXPECT_LT((projected - raw).norm(), 1e-12 * raw.norm()) << "tet " << t;
  }
}

TEST(ExactStiffness, WarpedAndExactAgreeAtRest) {
  const Fixture f;
  for (const Mat3& R : {Mat3(Mat3::Identity()), rotation(2.5, Vec3(1, 1, -1))}) {
    const Matrix3Xd x = (R * f.cage.rest_positions).colwise() + Vec3(3, -1, 2);
    for (TetIndex t = 0; t < f.elasticity.tet_count(); ++t) {
      const Mat12 warped = f.elasticity.stiffness(t, R);
      for (const bool project : {false, true}) {
        const Mat12 exact = f.elasticity.exact_stiffness(t, x, project);
        EXPECT_LT((exact - warped).norm(), 1e-10 * warped.norm()) << "tet " << t << " project " << project;
      }
    }
  }
}

TEST(ExactStiffness, EvaluateUsesTheProjectedExactStiffness) {
  const Fixture f;
  const Matrix3Xd x = rotation(0.3, Vec3(1, 0, 0)) * perturbed(f.cage.rest_positions, 0.3, 31);
  ElementBuffers buffers;
  f.elasticity.evaluate(x, StiffnessModel::Exact, false, buffers);
  for (TetIndex t = 0; t < f.elasticity.tet_count(); ++t) {
    EXPECT_LT((buffers.stiffness[t] - f.elasticity.exact_stiffness(t, x, true)).norm(),
              1e-12 * buffers.stiffness[t].norm());
  }
  // And the forces it returns are the true forces.
  Matrix3Xd summed = Matrix3Xd::Zero(3, x.cols());
  for (TetIndex t = 0; t < f.elasticity.tet_count(); ++t) {
    for (int i = 0; i < 4; ++i) summed.col(f.cage.tets(i, t)) += buffers.forces[t].col(i);
  }
  EXPECT_LT((summed - true_forces(f.elasticity, x)).norm(), 1e-12 * summed.norm());
}

// --- Time stepping ---------------------------------------------------------------

using Beam = testing::SpinningBeam;

TEST(ExactStiffness, ImplicitStepIsStableForASpinningStretchedBeamAtLargeSteps) {
  const Beam beam;
  for (const double youngs : {1e5, 1e9}) {
    auto body = beam.make(1.3, 20.0, youngs);
    const double initial = body->energy();
    StepSettings settings;
    settings.dt = 0.1;
    settings.gravity.setZero();
    settings.stiffness = StiffnessModel::Exact;
    double highest = initial;
    for (int i = 0; i < 60; ++i) {
      ASSERT_EQ(body->step(settings), SolveStatus::Converged) << "E " << youngs << " step " << i;
      ASSERT_TRUE(body->positions().allFinite() && body->velocities().allFinite()) << "E " << youngs << " step " << i;
      highest = std::max(highest, body->energy());
    }
    // Backward Euler only dissipates: with the exact (projected) Hessian the energy must
    // never rise above the start (the 1 % allows for the linearization in one step).
    EXPECT_LE(highest, 1.01 * initial) << "E " << youngs;
    EXPECT_LT(body->energy(), initial) << "E " << youngs;
  }
}

TEST(ExactStiffness, AStiffSpinningBodyAtLargeStepsStaysUnstretchedOnlyWithTheExactModel) {
  // A steel-stiff bar (E = 1e11) spinning at 3 rad/s, dt = 0.1 (0.3 rad per step). Each
  // step moves the nodes along straight lines, x += h v, which stretches a spinning body
  // radially by ~(hω)²/2 = 4.5 %: at E = 1e11 that is ~1e6 J of strain against 0.2 J of
  // spin. Both models start from the same (rest) Hessian, so the first step stretches
  // both; the exact Hessian then knows the stretch is rotation and undoes it, the warped
  // one re-creates it every step. Measured after 10 steps: warped 1.1e6 J, exact 3e-13 J
  // (the exact model also damps the spin, see the measurement below).
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(0.3, 0.1, 0.1), 3, 1, 1);
  const Vec3 centre = cage.rest_positions.rowwise().mean();
  double strain[2] = {0, 0};
  for (const StiffnessModel model : {StiffnessModel::Warped, StiffnessModel::Exact}) {
    ImplicitIntegrator body(cage.rest_positions, cage.tets, Material{.density = 1000, .youngs_modulus = 1e11});
    Matrix3Xd v(3, body.node_count());
    for (Index n = 0; n < body.node_count(); ++n) v.col(n) = Vec3(0, 3, 0).cross(body.positions().col(n) - centre);
    body.set_velocities(v);
    StepSettings settings;
    settings.dt = 0.1;
    settings.gravity.setZero();
    settings.stiffness = model;
    for (int i = 0; i < 10; ++i) ASSERT_EQ(body.step(settings), SolveStatus::Converged);
    strain[model == StiffnessModel::Exact] = body.elasticity().energy(body.positions());
  }
  std::printf("stiff bar spinning at 0.3 rad/step, strain energy after 10 steps: warped %.3g J, exact %.3g J\n",
              strain[0], strain[1]);
  EXPECT_LT(strain[1], 1e-6);
}

TEST(ExactStiffness, MeasuredTradeOfExactVersusWarpedOnAFastSpinningBeam) {
  // A free beam (2 m, E = 1 MPa) spinning at 10 rad/s about z, with some bending, for
  // 0.5 s. The true motion keeps E and L; the reference for the tip is the exact model
  // at dt = 2.5e-4 (its own drift is printed too). Measured (this machine's build):
  //   dt = 0.05 (0.5 rad/step): warped E/E0 2.05 (gains), exact 0.03 (L/L0 0.26);
  //   dt = 0.01: warped E/E0 0.94, L/L0 0.99, tip 0.07 m off; exact E/E0 0.42,
  //   L/L0 0.71, tip 0.9 m off (the spin has slowed);
  //   beam stretched 30 % at 20 rad/s, dt = 0.1: warped peaks at 5.6 E0, exact at E0.
  // Why: the exact Hessian of a stressed, spinning body has the geometric stiffness
  // m ω² against the rotation, so backward Euler damps the spin like any oscillation
  // of frequency ω (a factor ≈ 1/(1 + h²ω²) per step); the warped Hessian has no
  // stiffness along the rotation, so the spin is integrated explicitly: accurate while
  // hω is small, energy-gaining when it is not. Exact buys unconditional dissipation
  // (never gains energy), not accuracy for fast spins.
  const Beam beam;
  const double duration = 0.5;
  const testing::SpinOutcome reference = testing::spin(beam, StiffnessModel::Exact, 2.5e-4, duration);
  std::printf("spinning beam, 10 rad/s for %.1f s, reference dt=2.5e-4: E/E0 %.4f, L/L0 %.4f\n", duration,
              reference.energy_ratio, reference.momentum_ratio);
  for (const double dt : {0.05, 0.01}) {
    for (const StiffnessModel model : {StiffnessModel::Warped, StiffnessModel::Exact}) {
      const testing::SpinOutcome run = testing::spin(beam, model, dt, duration);
      std::printf("  dt=%-5g %-6s: E/E0 %.4f, L/L0 %.4f, tip error %.4f m\n", dt,
                  model == StiffnessModel::Warped ? "warped" : "exact", run.energy_ratio, run.momentum_ratio,
                  (run.tip - reference.tip).norm());
      EXPECT_TRUE(run.tip.allFinite() && run.tail.allFinite());
      if (model == StiffnessModel::Exact) {
        EXPECT_LE(run.energy_ratio, 1.0);  // the exact model never gains energy
      }
    }
  }
  // The stretched beam of the stability test, at dt = 0.1, 20 rad/s: peak energy over 6 s.
  for (const StiffnessModel model : {StiffnessModel::Warped, StiffnessModel::Exact}) {
    auto body = beam.make(1.3, 20.0);
    const double initial = body->energy();
    StepSettings settings;
    settings.dt = 0.1;
    settings.gravity.setZero();
    settings.stiffness = model;
    double highest = initial;
    for (int i = 0; i < 60 && body->step(settings) == SolveStatus::Converged; ++i) highest = std::max(highest, body->energy());
    std::printf("  stretched beam at 20 rad/s, dt=0.1, %-6s: peak E/E0 %.3g, final E/E0 %.3g\n",
                model == StiffnessModel::Warped ? "warped" : "exact", highest / initial, body->energy() / initial);
  }
}

}  // namespace
}  // namespace fissure::sim
