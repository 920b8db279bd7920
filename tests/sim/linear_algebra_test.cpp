// The step's numerical kernels: the fast polar rotation, the closed-form warped
// stiffness product, conjugate gradients, the sparse Cholesky factor and the contact
// response's block-Jacobi preconditioner, dense and sparse blocks.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>

#include <tbb/global_control.h>

#include "player/sim/block_jacobi.h"
#include "player/sim/conjugate_gradient.h"
#include "player/sim/corotated_elasticity.h"
#include "player/sim/sparse_blocks.h"
#include "player/sim/sparse_cholesky.h"
#include "tests/support/procedural.h"

namespace fissure::sim {
namespace {

Mat3 random_matrix(std::mt19937& rng, double spread) {
  std::uniform_real_distribution<double> u(-spread, spread);
  Mat3 m;
  for (int k = 0; k < 9; ++k) m.data()[k] = u(rng);
  return m;
}

TEST(PolarRotation, NewtonIterationMatchesTheSignedSvd) {
  std::mt19937 rng(7);
  int newton_cases = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    // Rotations times stretches from mild to strong, some nearly flat.
    const Mat3 rotation = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
    const Mat3 F = rotation * (Mat3::Identity() + random_matrix(rng, trial % 2 == 0 ? 0.3 : 0.9));
    const SignedSvd svd = signed_svd(F);
    const Mat3 expected = svd.U * svd.V.transpose();
    const Mat3 Q = polar_rotation(F);
    EXPECT_LT((Q - expected).norm(), 1e-10) << "F =\n" << F;
    EXPECT_NEAR(Q.determinant(), 1.0, 1e-12);
    if (F.determinant() > 0.0) ++newton_cases;
  }
  EXPECT_GT(newton_cases, 1000);  // the fast path was exercised
}

TEST(PolarRotation, InvertedFlatAndCollapsedTetsGetProperRotations) {
  const Mat3 inverted = Vec3(1.0, 1.0, -0.5).asDiagonal();
  const Mat3 flat = Vec3(1.0, 2.0, 0.0).asDiagonal();
  for (const Mat3& F : {inverted, flat, Mat3(Mat3::Zero())}) {
    const Mat3 Q = polar_rotation(F);
    EXPECT_NEAR(Q.determinant(), 1.0, 1e-12);
    EXPECT_LT((Q * Q.transpose() - Mat3::Identity()).norm(), 1e-12);
  }
  EXPECT_LT((polar_rotation(inverted) - Mat3::Identity()).norm(), 1e-12);  // the reflection goes onto σ₃
}

TEST(PolarRotation, BatchesMatchOneAtATimeWithInvertedAndShortBatches) {
  std::mt19937 rng(11);
  std::vector<Mat3> F;
  for (int trial = 0; trial < 400; ++trial) {
    const Mat3 rotation = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
    F.push_back(rotation * (Mat3::Identity() + random_matrix(rng, trial % 3 == 0 ? 0.9 : 0.05)));
  }
  // Lanes Newton does not take, among lanes it does: they get polar_rotation's SVD answer.
  F[5] = Vec3(1.0, 1.0, -0.5).asDiagonal();  // inverted
  F[6] = Vec3(1.0, 2.0, 0.0).asDiagonal();   // flat
  F[7] = Mat3::Zero();                       // collapsed
  F[9] = Mat3::Constant(std::numeric_limits<double>::quiet_NaN());  // must not harm its batch's other lanes
  for (int count = 1; count <= kLanes; ++count) {
    for (std::size_t first = 0; first + count <= F.size(); first += count) {
      Mat3 Q[kLanes];
      polar_rotations(&F[first], Q, count);
      for (int l = 0; l < count; ++l) {
        const Mat3 expected = polar_rotation(F[first + l]);
        if (!F[first + l].allFinite()) {  // NaN in, NaN out (for the step's non-finite check)
          EXPECT_TRUE(Q[l].hasNaN());
          continue;
        }
        EXPECT_LT((Q[l] - expected).norm(), 1e-10) << "matrix " << first + l << " in a batch of " << count;
        EXPECT_NEAR(Q[l].determinant(), 1.0, 1e-12);
      }
    }
  }
}

TEST(StiffnessProduct, MatchesTheAssembledTetStiffnessInBothModelsOneAtATimeAndInBatches) {
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(1.0, 3.0, 1.0), 1, 3, 1);  // full and short batches
  const CorotatedElasticity elasticity(cage.rest_positions, cage.tets, Material{.youngs_modulus = 1e6});
  ASSERT_GT(elasticity.tet_count() % kLanes, 0u);
  std::mt19937 rng(3);
  Matrix3Xd x = cage.rest_positions;
  const Mat3 turn = Eigen::AngleAxisd(0.7, Vec3::UnitZ()).toRotationMatrix();
  for (Eigen::Index n = 0; n < x.cols(); ++n) x.col(n) = turn * x.col(n) + 0.1 * random_matrix(rng, 1.0).col(0);
  const auto expect_near = [](const Mat34& product, const Eigen::Matrix<double, 12, 1>& expected, TetIndex t) {
    EXPECT_LT((Eigen::Map<const Eigen::Matrix<double, 12, 1>>(product.data()) - expected).norm(), 1e-12 * expected.norm())
        << "tet " << t;
  };
  for (const StiffnessModel model : {StiffnessModel::Warped, StiffnessModel::Exact}) {
    ElementBuffers buffers;
    elasticity.evaluate(x, model, false, buffers);
    std::vector<Mat34> u(elasticity.tet_count());
    std::vector<Eigen::Matrix<double, 12, 1>> expected(elasticity.tet_count());
    for (TetIndex t = 0; t < elasticity.tet_count(); ++t) {
      const Mat12 K = model == StiffnessModel::Warped ? elasticity.stiffness(t, buffers.rotations[t])
                                                      : elasticity.exact_stiffness(t, x, true);
      u[t] = random_matrix(rng, 1.0) * Mat34::Random();
      Eigen::Matrix<double, 12, 1> stacked;
      for (int j = 0; j < 4; ++j) stacked.segment<3>(3 * j) = u[t].col(j);
      expected[t] = K * stacked;
      expect_near(elasticity.stiffness_times(t, buffers, u[t]), expected[t], t);
    }
    for (TetIndex first = 0; first < elasticity.tet_count(); first += kLanes) {
      const int count = static_cast<int>(std::min<std::size_t>(kLanes, elasticity.tet_count() - first));
      Mat34 products[kLanes];
      elasticity.stiffness_times(first, count, buffers, &u[first], products);
      for (int l = 0; l < count; ++l) expect_near(products[l], expected[first + l], first + l);
    }
  }
}

/// A random sparse symmetric positive-definite matrix (a graph Laplacian plus a diagonal).
Eigen::SparseMatrix<double> random_spd(int n, std::mt19937& rng) {
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::uniform_real_distribution<double> weight(0.1, 10.0);
  std::vector<Eigen::Triplet<double>> entries;
  for (int i = 0; i < n; ++i) entries.emplace_back(i, i, 1e-3);
  for (int e = 0; e < 4 * n; ++e) {
    const int i = pick(rng), j = pick(rng);
    if (i == j) continue;
    const double w = weight(rng);
    entries.emplace_back(i, i, w);
    entries.emplace_back(j, j, w);
    entries.emplace_back(i, j, -w);
    entries.emplace_back(j, i, -w);
  }
  Eigen::SparseMatrix<double> A(n, n);
  A.setFromTriplets(entries.begin(), entries.end());
  return A;
}

TEST(ConjugateGradient, SolvesASymmetricPositiveDefiniteSystemToTheTolerance) {
  std::mt19937 rng(11);
  const Eigen::SparseMatrix<double> A = random_spd(300, rng);
  const Eigen::VectorXd b = Eigen::VectorXd::Random(300);
  Eigen::VectorXd product;
  symmetric_product(A, b, product);
  EXPECT_LT((product - A * b).norm(), 1e-12 * (A * b).norm());
  const Eigen::VectorXd inverse_diagonal = A.diagonal().cwiseInverse();
  for (const double tolerance : {1e-4, 1e-10}) {
    Eigen::VectorXd x = Eigen::VectorXd::Zero(300);
    const ConjugateGradientResult result = conjugate_gradient(
        A, b, x, [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { z = inverse_diagonal.cwiseProduct(r); },
        tolerance, 10000);
    EXPECT_TRUE(result.converged);
    EXPECT_LE((b - A * x).norm(), tolerance * b.norm());
  }
  // An exact preconditioner converges in one iteration.
  SparseCholesky cholesky;
  cholesky.analyze(A);
  ASSERT_TRUE(cholesky.factorize(A));
  Eigen::VectorXd x = Eigen::VectorXd::Zero(300);
  const ConjugateGradientResult exact = conjugate_gradient(
      A, b, x, [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { cholesky.solve(r, z); }, 1e-10, 100);
  EXPECT_TRUE(exact.converged);
  EXPECT_EQ(exact.iterations, 1);
}

// A guess already within tolerance ‖b‖ (the contact response's warm-started inner
// solves) is left as it is by default, and improved to the asked share of its own
// residual with residual_reduction.
TEST(ConjugateGradient, AResidualReductionImprovesAGuessAlreadyWithinTheTolerance) {
  std::mt19937 rng(13);
  const Eigen::SparseMatrix<double> A = random_spd(200, rng);
  const Eigen::VectorXd solution = Eigen::VectorXd::Random(200);
  const Eigen::VectorXd b = A * solution;
  const Eigen::VectorXd guess = solution + 1e-6 * Eigen::VectorXd::Random(200);
  const double start = (b - A * guess).norm();
  ASSERT_LT(start, 1e-3 * b.norm());
  const Eigen::VectorXd inverse_diagonal = A.diagonal().cwiseInverse();
  const auto jacobi = [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { z = inverse_diagonal.cwiseProduct(r); };
  Eigen::VectorXd x = guess;
  EXPECT_EQ(conjugate_gradient(A, b, x, jacobi, 1e-3, 1000).iterations, 0);
  EXPECT_EQ(x, guess);
  const ConjugateGradientResult reduced = conjugate_gradient(A, b, x, jacobi, 1e-3, 1000, 0.1);
  EXPECT_TRUE(reduced.converged);
  EXPECT_GT(reduced.iterations, 0);
  EXPECT_LE((b - A * x).norm(), 0.1 * start);
}

TEST(ConjugateGradient, ZeroRightHandSideGivesZeroAndAnIndefiniteMatrixStops) {
  std::mt19937 rng(5);
  const Eigen::SparseMatrix<double> A = random_spd(50, rng);
  const auto identity = [](const Eigen::VectorXd& r, Eigen::VectorXd& z) { z = r; };
  Eigen::VectorXd x = Eigen::VectorXd::Ones(50);
  EXPECT_TRUE(conjugate_gradient(A, Eigen::VectorXd::Zero(50), x, identity, 1e-8, 100).converged);
  EXPECT_EQ(x, Eigen::VectorXd::Zero(50));
  const Eigen::SparseMatrix<double> negative = -A;
  x.setZero();
  const ConjugateGradientResult result =
      conjugate_gradient(negative, Eigen::VectorXd::Ones(50), x, identity, 1e-8, 100);
  EXPECT_FALSE(result.converged);
  EXPECT_LT(result.iterations, 100);  // stopped at the first non-positive curvature
}

TEST(SparseCholesky, RefusesAnIndefiniteMatrixAndKeepsItsAnalysis) {
  std::mt19937 rng(9);
  const Eigen::SparseMatrix<double> A = random_spd(80, rng);
  SparseCholesky cholesky;
  cholesky.analyze(A);
  const Eigen::SparseMatrix<double> negative = -A;
  EXPECT_FALSE(cholesky.factorize(negative));
  EXPECT_FALSE(cholesky.factorized());
  ASSERT_TRUE(cholesky.factorize(A));  // same pattern: the analysis is reused
  const Eigen::VectorXd b = Eigen::VectorXd::Random(80);
  Eigen::VectorXd x;
  cholesky.solve(b, x);
  EXPECT_LT((A * x - b).norm(), 1e-10 * b.norm());
}

/// An implicit-step matrix M − h²K of a 4×1×1 m beam (both triangles): large
/// supernodes, a condition number like the player's.
Eigen::SparseMatrix<double> beam_system_matrix(int nx = 12, int ny = 3, int nz = 3) {
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3(4, 1, 1), nx, ny, nz);
  const Material material{.density = 1000, .youngs_modulus = 1e6, .poisson_ratio = 0.3};
  const CorotatedElasticity elasticity(cage.rest_positions, cage.tets, material);
  const double h = 1.0 / 240.0;
  std::vector<Eigen::Triplet<double>> entries;
  for (TetIndex t = 0; t < elasticity.tet_count(); ++t) {
    const Mat12 K = elasticity.stiffness(t, Mat3::Identity());
    const double mass = material.density * elasticity.rest_volume(t) / 4.0;
    for (int i = 0; i < 4; ++i) {
      for (int a = 0; a < 3; ++a) {
        const int row = 3 * static_cast<int>(cage.tets(i, t)) + a;
        entries.emplace_back(row, row, mass);
        for (int j = 0; j < 4; ++j) {
          for (int b = 0; b < 3; ++b) {
            entries.emplace_back(row, 3 * static_cast<int>(cage.tets(j, t)) + b, -h * h * K(3 * i + a, 3 * j + b));
          }
        }
      }
    }
  }
  const auto n = static_cast<int>(3 * cage.node_count());
  Eigen::SparseMatrix<double> A(n, n);
  A.setFromTriplets(entries.begin(), entries.end());
  return A;
}

TEST(SparseCholesky, DoubleSolvesToRoundoffAndSingleIsASymmetricNearbyInverse) {
  const Eigen::SparseMatrix<double> A = beam_system_matrix();
  const Eigen::Index n = A.rows();
  SparseCholesky cholesky;
  cholesky.analyze(A);
  ASSERT_TRUE(cholesky.factorize(A, FactorPrecision::Double));
  EXPECT_GT(cholesky.factor_nonzeros(), static_cast<std::size_t>(A.nonZeros() / 2));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::VectorXd b = Eigen::VectorXd::NullaryExpr(n, [&]() { return u(rng); });
  const Eigen::VectorXd c = Eigen::VectorXd::NullaryExpr(n, [&]() { return u(rng); });
  Eigen::VectorXd x_double, x_single, y_single;
  cholesky.solve(b, x_double);
  EXPECT_LT((A * x_double - b).norm(), 1e-10 * b.norm());
  // Against an independent factorization.
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> reference(A);
  const Eigen::VectorXd x_reference = reference.solve(b);
  EXPECT_LT((x_double - x_reference).norm(), 1e-9 * x_reference.norm());

#if defined(FISSURE_WITH_CHOLMOD)  // the Eigen fallback solves in double whatever it is asked
  ASSERT_TRUE(cholesky.factorize(A, FactorPrecision::Single));
  cholesky.solve(b, x_single);
  cholesky.solve(c, y_single);
  // Float rounding of L: a few digits are lost, not more (a preconditioner's job) ...
  const double error = (x_single - x_reference).norm() / x_reference.norm();
  EXPECT_LT(error, 1e-3);
  EXPECT_GT(error, 1e-14);  // ... and the single-precision values were really used
  // ... and it is still the inverse of a symmetric positive-definite matrix L̃ L̃ᵀ.
  EXPECT_NEAR(c.dot(x_single), b.dot(y_single), 1e-12 * std::abs(c.dot(x_single)) + 1e-300);
  EXPECT_GT(b.dot(x_single), 0.0);
#endif
}

#if defined(FISSURE_WITH_CHOLMOD)  // the Eigen fallback solves on one thread
TEST(SparseCholesky, TwoThreadSolvesAreExactAndIndependentOfTheThreadCount) {
  // Large enough (~0.5M factor entries) for the solves to split over two threads.
  const Eigen::SparseMatrix<double> A = beam_system_matrix(30, 6, 6);
  const Eigen::Index n = A.rows();
  SparseCholesky cholesky;
  cholesky.analyze(A);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(n, -1.0, 1.0).array().sin();
  for (const FactorPrecision precision : {FactorPrecision::Double, FactorPrecision::Single}) {
    ASSERT_TRUE(cholesky.factorize(A, precision));
    EXPECT_TRUE(cholesky.solves_on_two_threads());
    Eigen::VectorXd one_thread, two_threads;
    {
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
      cholesky.solve(b, one_thread);
    }
    {
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
      cholesky.solve(b, two_threads);
    }
    EXPECT_EQ(one_thread, two_threads);  // bit for bit
    const double tolerance = precision == FactorPrecision::Double ? 1e-10 : 1e-3;
    EXPECT_LT((A * one_thread - b).norm(), tolerance * b.norm());
  }
  // A small factor is solved on one thread.
  const Eigen::SparseMatrix<double> small = beam_system_matrix();
  SparseCholesky small_cholesky;
  small_cholesky.analyze(small);
  ASSERT_TRUE(small_cholesky.factorize(small));
  EXPECT_FALSE(small_cholesky.solves_on_two_threads());
}
#endif


/// A random symmetric positive-definite matrix of `nodes` 3×3 blocks.
Eigen::MatrixXd random_spd(std::mt19937& rng, Eigen::Index nodes) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd B(3 * nodes, 3 * nodes);
  for (Eigen::Index k = 0; k < B.size(); ++k) B.data()[k] = u(rng);
  return B * B.transpose() + Eigen::MatrixXd::Identity(3 * nodes, 3 * nodes);
}

/// Groups of 2 nodes (fixed size), 5 nodes (dynamic) and 1 node, and node 4 in none.
std::vector<std::vector<Eigen::Index>> mixed_groups() { return {{9, 0}, {3, 6, 15, 18, 21}, {24}}; }

TEST(BlockJacobi, SolvesEachGroupsBlockExactlyAndLeavesOtherRowsAlone) {
  std::mt19937 rng(3);
  const Eigen::MatrixXd A = random_spd(rng, 9);
  BlockJacobi blocks;
  blocks.set_groups(mixed_groups(), A.rows());
  for (Eigen::Index a = 0; a < 9; ++a) {
    for (Eigen::Index b = 0; b < 9; ++b) blocks.add(3 * a, 3 * b, A.block<3, 3>(3 * a, 3 * b));
  }
  blocks.keep_as_base();
  blocks.factor();
  const Eigen::VectorXd r = Eigen::VectorXd::LinSpaced(A.rows(), -1.0, 2.0);
  Eigen::VectorXd z = Eigen::VectorXd::Constant(A.rows(), 7.0);
  blocks.solve(r, z);
  for (const std::vector<Eigen::Index>& group : mixed_groups()) {
    const auto n = static_cast<Eigen::Index>(group.size());
    Eigen::MatrixXd block(3 * n, 3 * n);
    Eigen::VectorXd local(3 * n), expected_z(3 * n);
    for (Eigen::Index i = 0; i < n; ++i) {
      local.segment<3>(3 * i) = r.segment<3>(group[i]);
      for (Eigen::Index j = 0; j < n; ++j) block.block<3, 3>(3 * i, 3 * j) = A.block<3, 3>(group[i], group[j]);
    }
    const Eigen::VectorXd expected = block.llt().solve(local);
    for (Eigen::Index i = 0; i < n; ++i) {
      EXPECT_LT((z.segment<3>(group[i]) - expected.segment<3>(3 * i)).norm(), 1e-12 * expected.norm()) << "row " << group[i];
    }
  }
  EXPECT_FALSE(blocks.covers(12));
  EXPECT_EQ(z.segment<3>(12), Vec3::Constant(7.0));  // node 4 is in no group
}

TEST(BlockJacobi, AnOuterProductTermEqualsItsPairsAndResetReturnsToTheBase) {
  std::mt19937 rng(5);
  const Eigen::MatrixXd A = random_spd(rng, 9);
  BlockJacobi by_pairs, by_outer;
  for (BlockJacobi* blocks : {&by_pairs, &by_outer}) {
    blocks->set_groups(mixed_groups(), A.rows());
    for (Eigen::Index a = 0; a < 9; ++a) blocks->add(3 * a, 3 * a, A.block<3, 3>(3 * a, 3 * a));
    blocks->keep_as_base();
    blocks->add(0, 0, 1e6 * Mat3::Identity());  // dropped by reset()
    blocks->reset();
  }
  // A contact row across groups: entries in the fixed group, the dynamic one and node 4.
  const std::vector<Eigen::Index> rows{0, 9, 3, 15, 12};
  const std::vector<double> weights{0.25, 0.75, -0.5, -0.5, 1.0};
  const Vec3 n = Vec3(1.0, 2.0, 2.0) / 3.0;
  const Mat3 term = 3.0 * n * n.transpose() + 0.5 * (Mat3::Identity() - n * n.transpose());
  BlockJacobi::OuterRows outer;
  outer.count = static_cast<int>(rows.size());
  std::copy(rows.begin(), rows.end(), outer.rows.begin());
  std::copy(weights.begin(), weights.end(), outer.weights.begin());
  // Twice (the same rows, the second term 2×), as one set of blocks would have them.
  by_outer.set_outer_rows(std::vector{outer, outer});
  by_outer.add(0, 0, 1e6 * Mat3::Identity());  // set_outer_terms() starts from the base too
  by_outer.set_outer_terms(std::vector<Mat3>{term, 2.0 * term});
  for (std::size_t e = 0; e < rows.size(); ++e) {
    for (std::size_t f = 0; f < rows.size(); ++f) by_pairs.add(rows[e], rows[f], 3.0 * weights[e] * weights[f] * term);
  }
  by_pairs.factor();
  by_outer.factor();
  const Eigen::VectorXd r = Eigen::VectorXd::LinSpaced(A.rows(), 1.0, 3.0);
  Eigen::VectorXd z_pairs = Eigen::VectorXd::Zero(A.rows()), z_outer = z_pairs;
  by_pairs.solve(r, z_pairs);
  by_outer.solve(r, z_outer);
  EXPECT_LT((z_pairs - z_outer).norm(), 1e-14 * z_pairs.norm());
  EXPECT_LT(std::abs(z_outer[0]), 1.0);  // the 1e6 added before reset() is gone
}

TEST(BlockJacobi, ABlockThatIsNotPositiveDefiniteFallsBackToItsDiagonal) {
  BlockJacobi blocks;
  blocks.set_groups({{0, 3}}, 6);
  // [I 3I; 3I 4I]: its determinant per axis is 4 − 9 < 0.
  blocks.add(0, 0, Mat3::Identity());
  blocks.add(3, 3, 4.0 * Mat3::Identity());
  blocks.add(0, 3, 3.0 * Mat3::Identity());
  blocks.add(3, 0, 3.0 * Mat3::Identity());
  blocks.factor();
  const Eigen::VectorXd r = Eigen::VectorXd::Ones(6);
  Eigen::VectorXd z = Eigen::VectorXd::Zero(6);
  blocks.solve(r, z);
  EXPECT_EQ(z.head<3>(), Vec3::Ones());
  EXPECT_EQ(z.tail<3>(), Vec3::Constant(0.25));
}

/// The dense matrix of `group`'s rows of A plus each term's Σ wₑ w_f T at its rows in
/// the group, and r on those rows.
std::pair<Eigen::MatrixXd, Eigen::VectorXd> group_block(const std::vector<Eigen::Index>& group, const Eigen::MatrixXd& A,
                                                        std::span<const BlockJacobi::OuterRows> terms,
                                                        std::span<const Mat3> values, const Eigen::VectorXd& r) {
  const auto n = static_cast<Eigen::Index>(group.size());
  const auto local = [&](Eigen::Index row) -> Eigen::Index {
    const auto found = std::find(group.begin(), group.end(), row);
    return found == group.end() ? -1 : static_cast<Eigen::Index>(found - group.begin());
  };
  Eigen::MatrixXd block(3 * n, 3 * n);
  Eigen::VectorXd rhs(3 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    rhs.segment<3>(3 * i) = r.segment<3>(group[i]);
    for (Eigen::Index j = 0; j < n; ++j) block.block<3, 3>(3 * i, 3 * j) = A.block<3, 3>(group[i], group[j]);
  }
  for (std::size_t k = 0; k < terms.size(); ++k) {
    for (int e = 0; e < terms[k].count; ++e) {
      for (int f = 0; f < terms[k].count; ++f) {
        const Eigen::Index a = local(terms[k].rows[e]), b = local(terms[k].rows[f]);
        if (a >= 0 && b >= 0) block.block<3, 3>(3 * a, 3 * b) += terms[k].weights[e] * terms[k].weights[f] * values[k];
      }
    }
  }
  return {block, rhs};
}

/// A sparse operator: a chain of `nodes` nodes, each coupled to the next except across
/// `cut` (no coupling between nodes cut − 1 and cut), its blocks diagonally dominant,
/// so positive definite.
Eigen::MatrixXd chain_operator(std::mt19937& rng, Eigen::Index nodes, Eigen::Index cut = -1) {
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * nodes, 3 * nodes);
  for (Eigen::Index a = 0; a < nodes; ++a) {
    A.block<3, 3>(3 * a, 3 * a) = 8.0 * Mat3::Identity();
    if (a + 1 < nodes && a + 1 != cut) {
      const Mat3 c = random_matrix(rng, 1.0);
      A.block<3, 3>(3 * a, 3 * a + 3) = c;
      A.block<3, 3>(3 * a + 3, 3 * a) = c.transpose();
    }
  }
  return A;
}

/// Each nonzero 3×3 block of A as a base term of `blocks`.
void add_nonzero_blocks(const Eigen::MatrixXd& A, SparseBlocks& blocks) {
  for (Eigen::Index a = 0; a < A.rows() / 3; ++a) {
    for (Eigen::Index b = 0; b < A.rows() / 3; ++b) {
      if (!A.block<3, 3>(3 * a, 3 * b).isZero()) blocks.add(3 * a, 3 * b, A.block<3, 3>(3 * a, 3 * b));
    }
  }
}

TEST(SparseBlocks, SolveEachGroupsBlockWithItsTermsExactlyAndLeaveOtherRowsAlone) {
  std::mt19937 rng(7);
  const Eigen::MatrixXd A = chain_operator(rng, 12);
  const std::vector<std::vector<Eigen::Index>> groups{{0, 3, 6, 9, 12}, {30, 21, 24, 27}};  // node 5, 11 in none
  SparseBlocks blocks;
  blocks.set_groups(groups, A.rows());
  add_nonzero_blocks(A, blocks);
  // Two contact rows: one across both groups and a node in none, one inside the first
  // group between nodes A does not couple (a block outside A's pattern).
  BlockJacobi::OuterRows across, inside;
  across.count = 3;
  across.rows = {6, 24, 15};
  across.weights = {0.5, -1.0, 0.25};
  inside.count = 2;
  inside.rows = {0, 12};
  inside.weights = {1.0, -1.0};
  const std::vector<BlockJacobi::OuterRows> terms{across, inside};
  blocks.set_outer_rows(terms);
  const Vec3 n = Vec3(2.0, -1.0, 2.0) / 3.0;
  const Mat3 term = 3.0 * n * n.transpose() + 0.5 * (Mat3::Identity() - n * n.transpose());
  const Eigen::VectorXd r = Eigen::VectorXd::LinSpaced(A.rows(), -2.0, 1.0);
  // Twice, with other values: each time from the base, not from the last values.
  for (const double scale : {10.0, 1.0}) {
    const std::vector<Mat3> values{scale * term, 2.0 * scale * term};
    blocks.set_outer_terms(values);
    Eigen::VectorXd z = Eigen::VectorXd::Constant(A.rows(), 7.0);
    blocks.solve(r, z);
    for (const std::vector<Eigen::Index>& group : groups) {
      const auto [block, rhs] = group_block(group, A, terms, values, r);
      const Eigen::VectorXd expected = block.llt().solve(rhs);
      for (std::size_t i = 0; i < group.size(); ++i) {
        EXPECT_LT((z.segment<3>(group[i]) - expected.segment<3>(3 * static_cast<Eigen::Index>(i))).norm(),
                  1e-12 * expected.norm())
            << "row " << group[i] << ", scale " << scale;
      }
    }
    EXPECT_FALSE(blocks.covers(15));
    EXPECT_EQ(z.segment<3>(15), Vec3::Constant(7.0));
    EXPECT_EQ(z.segment<3>(33), Vec3::Constant(7.0));
  }
}

// A block over kKeptFactorNodes nodes, once factored, keeps that factor when asked
// (the contact response's later outer iterations, contact_response.cpp): it solves with
// the first values, the small block with the new ones, and without the ask both are new.
TEST(SparseBlocks, ALargeBlockKeepsItsFirstFactorWhenAskedAndASmallOneNever) {
  std::mt19937 rng(11);
  constexpr auto kLarge = static_cast<Eigen::Index>(SparseBlocks::kKeptFactorNodes) + 1;
  const Eigen::MatrixXd A = chain_operator(rng, kLarge + 2, kLarge);  // a chain in each group
  std::vector<Eigen::Index> large, small{3 * kLarge, 3 * kLarge + 3};
  for (Eigen::Index a = 0; a < kLarge; ++a) large.push_back(3 * a);
  const std::vector<std::vector<Eigen::Index>> groups{large, small};
  SparseBlocks blocks;
  blocks.set_groups(groups, A.rows());
  add_nonzero_blocks(A, blocks);
  // One contact row in each group, between two of its nodes.
  BlockJacobi::OuterRows in_large, in_small;
  in_large.count = 2;
  in_large.rows = {0, 3 * (kLarge - 1)};
  in_large.weights = {1.0, -1.0};
  in_small.count = 2;
  in_small.rows = {small[0], small[1]};
  in_small.weights = {0.5, -0.5};
  const std::vector<BlockJacobi::OuterRows> terms{in_large, in_small};
  blocks.set_outer_rows(terms);
  const Vec3 n = Vec3(2.0, -1.0, 2.0) / 3.0;
  const std::vector<Mat3> first{20.0 * n * n.transpose(), 20.0 * n * n.transpose()};
  const std::vector<Mat3> second{Mat3::Zero(), Mat3::Zero()};  // the contacts turned off
  const Eigen::VectorXd r = Eigen::VectorXd::LinSpaced(A.rows(), -2.0, 1.0);
  // Whether `group` of z solves the block with `values`.
  const auto solves_with = [&](const Eigen::VectorXd& z, const std::vector<Eigen::Index>& group,
                               const std::vector<Mat3>& values) {
    const auto [block, rhs] = group_block(group, A, terms, values, r);
    const Eigen::VectorXd expected = block.llt().solve(rhs);
    double error = 0.0;
    for (std::size_t i = 0; i < group.size(); ++i) {
      error = std::max(error, (z.segment<3>(group[i]) - expected.segment<3>(3 * static_cast<Eigen::Index>(i))).norm());
    }
    return error < 1e-12 * expected.norm();
  };
  Eigen::VectorXd z = Eigen::VectorXd::Zero(A.rows());
  blocks.set_outer_terms(first, /*keep_large=*/true);
  blocks.set_outer_terms(second, /*keep_large=*/true);
  blocks.solve(r, z);
  EXPECT_TRUE(solves_with(z, large, first));
  EXPECT_FALSE(solves_with(z, large, second));  // the terms matter: the test can tell
  EXPECT_TRUE(solves_with(z, small, second));
  blocks.set_outer_terms(second);
  blocks.solve(r, z);
  EXPECT_TRUE(solves_with(z, large, second));
  EXPECT_TRUE(solves_with(z, small, second));
}

TEST(SparseBlocks, ABlockThatIsNotPositiveDefiniteFallsBackToItsDiagonal) {
  SparseBlocks blocks;
  blocks.set_groups({{0, 3}}, 6);
  // [I 3I; 3I 4I]: its determinant per axis is 4 − 9 < 0.
  blocks.add(0, 0, Mat3::Identity());
  blocks.add(3, 3, 4.0 * Mat3::Identity());
  blocks.add(0, 3, 3.0 * Mat3::Identity());
  blocks.add(3, 0, 3.0 * Mat3::Identity());
  blocks.set_outer_rows({});
  blocks.set_outer_terms({});
  const Eigen::VectorXd r = Eigen::VectorXd::Ones(6);
  Eigen::VectorXd z = Eigen::VectorXd::Zero(6);
  blocks.solve(r, z);
  EXPECT_EQ(z.head<3>(), Vec3::Ones());
  EXPECT_EQ(z.tail<3>(), Vec3::Constant(0.25));
}

}  // namespace
}  // namespace fissure::sim
