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

// energy() gives its last answer again for the same positions (the energy guard measures
// each substep's start, the last one's end): it must be the sum of the per-tet energies
// for the positions, material and tets it is asked about, never a stale one.
TEST(CorotatedElasticity, TheKeptEnergyIsAlwaysTheEnergyOfWhatIsAsked) {
  Fixture f;
  const Matrix3Xd x = perturbed(f.cage.rest_positions, 0.2, 1);
  const auto per_tet_sum = [&](const Matrix3Xd& at) {
    double sum = 0.0;
    for (TetIndex t = 0; t < f.elasticity.tet_count(); ++t) sum += f.elasticity.tet_energy(at, t);
    return sum;
  };
  const double first = f.elasticity.energy(x);
  EXPECT_NEAR(first, per_tet_sum(x), 1e-12 * first);
  EXPECT_EQ(f.elasticity.energy(x), first);  // asked again: the same bits
  Matrix3Xd moved = x;
  moved(1, 2) += 1e-3;
  EXPECT_NEAR(f.elasticity.energy(moved), per_tet_sum(moved), 1e-12 * first);
  EXPECT_NE(f.elasticity.energy(moved), first);
  f.elasticity.set_material({.density = 1000, .youngs_modulus = 2e5, .poisson_ratio = 0.3});
  EXPECT_NEAR(f.elasticity.energy(moved), per_tet_sum(moved), 1e-12 * first);
  // A corner pointed at another node (a split) with the same positions: the energy is
  // asked anew, here at a node moved away so that it differs.
  const double before_split = f.elasticity.energy(moved);
  const NodeIndex corner_node = f.elasticity.tets()(0, 0);
  Matrix3Xd with_copy(3, moved.cols() + 1);
  with_copy << moved, moved.col(corner_node) + Vec3(0.05, 0, 0);
  const double unsplit = f.elasticity.energy(with_copy);
  EXPECT_NEAR(unsplit, before_split, 1e-12 * first);  // the extra node is in no tet yet
  f.elasticity.replace_node(0, 0, static_cast<NodeIndex>(moved.cols()));
  EXPECT_NEAR(f.elasticity.energy(with_copy), per_tet_sum(with_copy), 1e-12 * first);
  EXPECT_NE(f.elasticity.energy(with_copy), unsplit);
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

// evaluate() runs the element loop four tets at a time on SIMD lanes; add_forces() and
// rotations() are the plain per-tet definitions (the ones the finite-difference tests
// check). They must agree, tet by tet, in both stiffness models, with inverted and
// collapsed tets among ordinary ones in the same batches.
TEST(CorotatedElasticity, BatchedEvaluationMatchesThePerTetDefinitions) {
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(3.0, 1.0, 1.0), 3, 1, 1);
  const CorotatedElasticity elasticity(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e5});
  ASSERT_GT(elasticity.tet_count() % kLanes, 0u);  // a short last batch too
  Matrix3Xd x = rotation(0.9, Vec3(1, -2, 1)) * perturbed(cage.rest_positions, 0.25, 5);
  x.col(cage.tets(0, 1)) = x.col(cage.tets(3, 1));  // tet 1 and its neighbours collapse or invert
  x.col(cage.tets(2, 6)) = 2.0 * x.col(cage.tets(0, 6)) - x.col(cage.tets(2, 6));
  std::vector<Mat3> q;
  elasticity.rotations(x, q);
  int inverted = 0;
  for (const StiffnessModel model : {StiffnessModel::Warped, StiffnessModel::Exact}) {
    ElementBuffers buffers;
    elasticity.evaluate(x, model, true, buffers);
    for (TetIndex t = 0; t < elasticity.tet_count(); ++t) {
      Matrix3Xd expected = Matrix3Xd::Zero(3, x.cols());
      std::vector<Mat3> one(elasticity.tet_count(), Mat3::Zero());
      one[t] = q[t];
      // add_forces over every tet with only tet t's rotation set gives tet t's forces
      // plus the others' at Q = 0 (zero force): so tet t's alone.
      elasticity.add_forces(x, one, expected);
      const double scale = 1.0 + expected.norm();
      EXPECT_LT((buffers.rotations[t] - q[t]).norm(), 1e-10) << "tet " << t;
      for (int i = 0; i < 4; ++i) {
        EXPECT_LT((buffers.forces[t].col(i) - expected.col(elasticity.tets()(i, t))).norm(), 1e-10 * scale)
            << "tet " << t << " corner " << i;
      }
      EXPECT_LT((buffers.rotated_gradients[t] - q[t] * elasticity.shape_gradients(t)).norm(), 1e-10) << "tet " << t;
      const Mat3 S = q[t].transpose() * [&] {
        Mat3 F = Mat3::Zero();
        for (int i = 0; i < 4; ++i) F += x.col(elasticity.tets()(i, t)) * elasticity.shape_gradients(t).col(i).transpose();
        if (model == StiffnessModel::Warped && F.determinant() < 0.0) ++inverted;
        return F;
      }();
      const Mat3 strain = 0.5 * (S + S.transpose()) - Mat3::Identity();
      const Material m{.youngs_modulus = 1e5};
      const Mat3 stress = q[t] * (2.0 * m.mu() * strain + m.lambda() * strain.trace() * Mat3::Identity()) * q[t].transpose();
      EXPECT_LT((buffers.stress[t] - stress).norm(), 1e-9 * (1.0 + stress.norm())) << "tet " << t;
    }
  }
  EXPECT_GT(inverted, 0);  // the SVD path was exercised inside a batch
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
