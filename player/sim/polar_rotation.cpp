// Polar rotations of deformation gradients (declared in polar_rotation.h): Higham's
// scaled Newton iteration, scalar and on SIMD lanes, with the signed SVD where Newton
// does not apply.
#include "player/sim/polar_rotation.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>

#include "common/assert.h"

namespace fissure::sim {

SignedSvd signed_svd(const Mat3& F) {
  const Eigen::JacobiSVD<Mat3> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  SignedSvd out{svd.matrixU(), svd.matrixV(), svd.singularValues()};
  // Make U and V proper rotations. A reflection (inverted tet) goes onto the smallest
  // singular value, which Eigen sorts last: U Vᵀ is then the closest proper rotation.
  if (out.U.determinant() < 0.0) {
    out.U.col(2) *= -1.0;
    out.sigma[2] *= -1.0;
  }
  if (out.V.determinant() < 0.0) {
    out.V.col(2) *= -1.0;
    out.sigma[2] *= -1.0;
  }
  return out;
}

namespace {

/// Newton's scaling γ = det^(−1/3). The scaling only speeds convergence up: any γ
/// near the optimum converges to the same rotation. Within 10% of det = 1 (nearly every
/// tet, and every tet after its first iterations) the second-order expansion
/// 1 − o/3 + 2o²/9 (o = det − 1) is within 2e-4 of it and saves the cube root, which
/// cost 4% of the element loop on the 987-tet bunny cage before (from 1e-3 on).
double newton_scaling(double det) {
  const double offset = det - 1.0;
  return std::abs(offset) < 0.1 ? 1.0 - offset * (1.0 / 3.0 - offset * (2.0 / 9.0)) : 1.0 / std::cbrt(det);
}

/// The polar rotation by the signed SVD: where Newton does not apply (inverted, flat,
/// collapsed) or did not converge. Eigen's SVD of a non-finite matrix returns arbitrary
/// (not even repeatable) values: the NaN is passed on instead, for the step's
/// non-finite check to report.
Mat3 svd_rotation(const Mat3& F) {
  if (!F.allFinite()) return Mat3::Constant(std::numeric_limits<double>::quiet_NaN());
  const SignedSvd svd = signed_svd(F);
  return svd.U * svd.V.transpose();
}

constexpr double kNewtonMinRelativeDeterminant = 1e-3;
constexpr int kNewtonMaxIterations = 12;

/// c = a × b on three doubles.
inline void cross(const double* a, const double* b, double* c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

}  // namespace

Mat3 polar_rotation(const Mat3& F) {
  // Higham's Newton iteration Q ← ½ (γ Q + Q⁻ᵀ/γ), γ = |det Q|^(−1/3), converges
  // quadratically to the polar rotation for det F > 0. It is about 10× cheaper than a
  // Jacobi SVD, which dominated the element loop.
  //
  // Written on plain column arrays because it is the element loop's largest cost: the
  // cofactor columns (q₁×q₂, q₂×q₀, q₀×q₁) give both Q⁻ᵀ = cofactor/det and det itself
  // (q₀·(q₁×q₂)), so an iteration is one set of cross products and one division.
  // Measured against the Eigen-expression version it replaces, alternating in one run:
  // the 987-tet cage's element loop 0.28 → 0.25 ms on one thread. What is left is the
  // latency of one dependent chain per tet (cofactors → det → γ → division).
  const double mean_square = F.squaredNorm() / 3.0;
  double q[9], cofactor[9];
  for (int k = 0; k < 9; ++k) q[k] = F.data()[k];
  const auto cofactors = [&]() {
    cross(q + 3, q + 6, cofactor);
    cross(q + 6, q, cofactor + 3);
    cross(q, q + 3, cofactor + 6);
    return q[0] * cofactor[0] + q[1] * cofactor[1] + q[2] * cofactor[2];
  };
  double det = cofactors();
  if (std::isfinite(det) && det > kNewtonMinRelativeDeterminant * mean_square * std::sqrt(mean_square)) {
    for (int iteration = 0; iteration < kNewtonMaxIterations; ++iteration) {
      const double gamma = newton_scaling(det);
      const double a = 0.5 * gamma, b = 0.5 / (gamma * det);
      double change = 0.0;
      for (int k = 0; k < 9; ++k) {
        const double next = a * q[k] + b * cofactor[k];
        change += (next - q[k]) * (next - q[k]);
        q[k] = next;
      }
      // Quadratic convergence: after a step of 1e-6 the error is ~1e-12.
      if (change < 1e-12) return Eigen::Map<const Mat3>(q);
      det = cofactors();
    }
  }
  return svd_rotation(F);
}

namespace {

/// The batch's Newton iterations on lanes (q[k][lane]: entry k of lane's matrix,
/// column-major). Sets, per lane, whether it converged; built for AVX2/FMA and for
/// baseline x86-64 and chosen at load time (the same machine always takes the same one).
FISSURE_SIMD_KERNEL void polar_newton_lanes(
    double (&q)[9][kLanes], bool (&converged)[kLanes]) {
  constexpr int L = kLanes;
  double cofactor[9][L], det[L], change[L], a[L], b[L];
  bool usable[L];
  const auto cofactors = [&]() {
    for (int l = 0; l < L; ++l) {
      // Columns q₀ = q[0..2], q₁ = q[3..5], q₂ = q[6..8]; cofactor columns q₁×q₂, q₂×q₀, q₀×q₁.
      cofactor[0][l] = q[4][l] * q[8][l] - q[5][l] * q[7][l];
      cofactor[1][l] = q[5][l] * q[6][l] - q[3][l] * q[8][l];
      cofactor[2][l] = q[3][l] * q[7][l] - q[4][l] * q[6][l];
      cofactor[3][l] = q[7][l] * q[2][l] - q[8][l] * q[1][l];
      cofactor[4][l] = q[8][l] * q[0][l] - q[6][l] * q[2][l];
      cofactor[5][l] = q[6][l] * q[1][l] - q[7][l] * q[0][l];
      cofactor[6][l] = q[1][l] * q[5][l] - q[2][l] * q[4][l];
      cofactor[7][l] = q[2][l] * q[3][l] - q[0][l] * q[5][l];
      cofactor[8][l] = q[0][l] * q[4][l] - q[1][l] * q[3][l];
      det[l] = q[0][l] * cofactor[0][l] + q[1][l] * cofactor[1][l] + q[2][l] * cofactor[2][l];
    }
  };
  cofactors();
  for (int l = 0; l < L; ++l) {
    double mean_square = 0.0;
    for (int k = 0; k < 9; ++k) mean_square += q[k][l] * q[k][l];
    mean_square /= 3.0;
    usable[l] = std::isfinite(det[l]) && det[l] > kNewtonMinRelativeDeterminant * mean_square * std::sqrt(mean_square);
    converged[l] = false;
  }
  for (int iteration = 0; iteration < kNewtonMaxIterations; ++iteration) {
    for (int l = 0; l < L; ++l) {
      // A lane Newton does not apply to iterates on the identity (cheap, finite); its
      // result is replaced by the SVD's.
      if (!usable[l]) det[l] = 1.0;
      const double gamma = newton_scaling(det[l]);
      a[l] = 0.5 * gamma;
      b[l] = 0.5 / (gamma * det[l]);
      change[l] = 0.0;
    }
    for (int k = 0; k < 9; ++k) {
      for (int l = 0; l < L; ++l) {
        const double next = a[l] * q[k][l] + b[l] * cofactor[k][l];
        change[l] += (next - q[k][l]) * (next - q[k][l]);
        q[k][l] = next;
      }
    }
    bool all = true;
    for (int l = 0; l < L; ++l) {
      converged[l] = converged[l] || change[l] < 1e-12;
      all = all && (converged[l] || !usable[l]);
    }
    if (all) break;
    cofactors();
  }
  for (int l = 0; l < L; ++l) converged[l] = converged[l] && usable[l];
}

}  // namespace

void polar_rotation_lanes(const double (&F)[9][kLanes], double (&Q)[9][kLanes], int count) {
  FISSURE_ASSERT(count >= 0 && count <= kLanes);
  std::copy(&F[0][0], &F[0][0] + 9 * kLanes, &Q[0][0]);
  bool converged[kLanes];
  polar_newton_lanes(Q, converged);
  for (int l = 0; l < count; ++l) {
    if (converged[l]) continue;
    Mat3 lane;  // Newton failed on this lane; the scalar one would too
    for (int k = 0; k < 9; ++k) lane.data()[k] = F[k][l];
    const Mat3 rotation = svd_rotation(lane);
    for (int k = 0; k < 9; ++k) Q[k][l] = rotation.data()[k];
  }
}

void polar_rotations(const Mat3* F, Mat3* Q, int count) {
  FISSURE_ASSERT(count >= 0 && count <= kLanes);
  double f[9][kLanes], q[9][kLanes];
  for (int l = 0; l < kLanes; ++l) {
    const Mat3& lane = l < count ? F[l] : F[0];  // a short batch repeats its first matrix
    for (int k = 0; k < 9; ++k) f[k][l] = lane.data()[k];
  }
  polar_rotation_lanes(f, q, count);
  for (int l = 0; l < count; ++l) {
    for (int k = 0; k < 9; ++k) Q[l].data()[k] = q[k][l];
  }
}

}  // namespace fissure::sim
