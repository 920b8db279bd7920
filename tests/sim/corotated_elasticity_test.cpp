#include "player/sim/corotated_elasticity.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "common/error.h"
#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"

namespace fissure::sim {
namespace {

using testing::perturbed;
using testing::rotation;

struct Fixture {
  TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(2.0, 1.0, 1.0), 2, 1, 1);
  Material material{.density = 1000, .youngs_modulus = 1e5, .poisson_ratio = 0.3};
  CorotatedElasticity elasticity{cage.rest_positions, cage.tets, material};
};

TEST(CorotatedElasticity, ForcesMatchFiniteDifferenceGradientOfTheEnergy) {
  const Fixture f;
  // Large deformation, including a rotation, so the corotation matters.
  const Matrix3Xd x = rotation(0.7, Vec3(1, 2, 3)) * perturbed(f.cage.rest_positions, 0.2, 1);
  std::vector<Mat3> q;
  f.elasticity.rotations(x, q);
  Matrix3Xd forces = Matrix3Xd::Zero(3, x.cols());
  f.elasticity.add_forces(x, q, forces);
  const double h = 1e-6;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    Matrix3Xd plus = x, minus = x;
    plus.data()[i] += h;
    minus.data()[i] -= h;
    const double gradient = (f.elasticity.energy(plus) - f.elasticity.energy(minus)) / (2 * h);
    EXPECT_NEAR(forces.data()[i], -gradient, 1e-5 * (1.0 + std::abs(gradient))) << "dof " << i;
  }
}

TEST(CorotatedElasticity, StiffnessIsTheDerivativeOfForcesWithRotationsFrozen) {
  const Fixture f;
  const Matrix3Xd x = rotation(-0.4, Vec3(0, 1, 1)) * perturbed(f.cage.rest_positions, 0.15, 2);
  std::vector<Mat3> q;
  f.elasticity.rotations(x, q);
  for (TetIndex t = 0; t < f.elasticity.tet_count(); ++t) {
    const Mat12 K = f.elasticity.stiffness(t, q[t]);
    const double h = 1e-6;
    for (int j = 0; j < 4; ++j) {
      for (int a = 0; a < 3; ++a) {
        Matrix3Xd plus = x, minus = x;
        plus(a, f.cage.tets(j, t)) += h;
        minus(a, f.cage.tets(j, t)) -= h;
        // Forces of this tet alone, with its rotation frozen at q[t].
        CorotatedElasticity single(f.cage.rest_positions, f.cage.tets.col(t), f.material);
        Matrix3Xd fp = Matrix3Xd::Zero(3, x.cols()), fm = Matrix3Xd::Zero(3, x.cols());
        single.add_forces(plus, {q[t]}, fp);
        single.add_forces(minus, {q[t]}, fm);
        for (int i = 0; i < 4; ++i) {
          const Vec3 derivative = (fp.col(f.cage.tets(i, t)) - fm.col(f.cage.tets(i, t))) / (2 * h);
          EXPECT_LT((K.block<3, 1>(3 * i, 3 * j + a) - derivative).norm(), 1e-4 * (1.0 + K.norm())) << "tet " << t;
        }
      }
    }
  }
}

TEST(CorotatedElasticity, StiffnessIsSymmetricAndNegativeSemiDefinite) {
  const Fixture f;
  const Matrix3Xd x = perturbed(f.cage.rest_positions, 0.3, 3);
  std::vector<Mat3> q;
  f.elasticity.rotations(x, q);
  for (TetIndex t = 0; t < f.elasticity.tet_count(); ++t) {
    const Mat12 K = f.elasticity.stiffness(t, q[t]);
    EXPECT_LT((K - K.transpose()).norm(), 1e-12 * K.norm());
    const Eigen::SelfAdjointEigenSolver<Mat12> eigen(K);
    EXPECT_LE(eigen.eigenvalues().maxCoeff(), 1e-9 * K.norm()) << "tet " << t;
  }
}

TEST(CorotatedElasticity, RigidMotionProducesNoForce) {
  const Fixture f;
  const Matrix3Xd x = (rotation(2.1, Vec3(0.3, -1, 0.5)) * f.cage.rest_positions).colwise() + Vec3(4, -2, 7);
  std::vector<Mat3> q;
  f.elasticity.rotations(x, q);
  Matrix3Xd forces = Matrix3Xd::Zero(3, x.cols());
  f.elasticity.add_forces(x, q, forces);
  EXPECT_LT(forces.norm(), 1e-9 * f.material.youngs_modulus);
  EXPECT_LT(f.elasticity.energy(x), 1e-12 * f.material.youngs_modulus);
}

TEST(CorotatedElasticity, InvertedTetsGetProperRotationsAndFiniteForces) {
  Mat3 F = Mat3::Identity();
  F(2, 2) = -0.5;  // inverted
  const Mat3 Q = polar_rotation(F);
  EXPECT_NEAR(Q.determinant(), 1.0, 1e-12);
  EXPECT_LT((Q * Q.transpose() - Mat3::Identity()).norm(), 1e-12);
  EXPECT_NEAR(polar_rotation(Mat3::Zero()).determinant(), 1.0, 1e-12);  // fully collapsed

  const Fixture f;
  Matrix3Xd x = f.cage.rest_positions;
  x.row(2) *= -1.0;  // mirror every tet through z = 0
  std::vector<Mat3> q;
  f.elasticity.rotations(x, q);
  Matrix3Xd forces = Matrix3Xd::Zero(3, x.cols());
  f.elasticity.add_forces(x, q, forces);
  EXPECT_TRUE(forces.allFinite());
  EXPECT_GT(forces.norm(), 0.0);  // an inverted body pushes back
}

TEST(CorotatedElasticity, InternalForcesSumToZero) {
  const Fixture f;
  const Matrix3Xd x = perturbed(f.cage.rest_positions, 0.3, 4);
  std::vector<Mat3> q;
  f.elasticity.rotations(x, q);
  Matrix3Xd forces = Matrix3Xd::Zero(3, x.cols());
  f.elasticity.add_forces(x, q, forces);
  EXPECT_LT(forces.rowwise().sum().norm(), 1e-9 * forces.norm());
}

TEST(Material, OutOfRangeValuesAreErrors) {
  EXPECT_THROW(validate(Material{.youngs_modulus = 0}), Error);
  EXPECT_THROW(validate(Material{.poisson_ratio = 0.5}), Error);
  EXPECT_THROW(validate(Material{.poisson_ratio = -0.1}), Error);
  EXPECT_THROW(validate(Material{.density = -1}), Error);
  EXPECT_THROW(validate(Material{.rayleigh_mass = std::numeric_limits<double>::quiet_NaN()}), Error);
  EXPECT_NO_THROW(validate(Material{.poisson_ratio = 0.499}));
}

}  // namespace
}  // namespace fissure::sim
