#include "player/sim/conjugate_gradient.h"

#include <algorithm>

#include <tbb/blocked_range.h>

#include "player/sim/lanes.h"

namespace fissure::sim {

void symmetric_product(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& x, Eigen::VectorXd& y) {
  y.resize(A.rows());
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  const double* values = A.valuePtr();
  // Rows of a few hundred: enough work per task to pay for the scheduling.
  parallel_for_range<Eigen::Index>(A.cols(), 512, [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index j = r.begin(); j != r.end(); ++j) {
      double sum = 0.0;
      for (int k = outer[j]; k < outer[j + 1]; ++k) sum += values[k] * x[inner[k]];
      y[j] = sum;
    }
  });
}

ConjugateGradientResult conjugate_gradient(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& b,
                                           Eigen::VectorXd& x, const ApplyPreconditioner& precondition,
                                           double tolerance, int max_iterations, double residual_reduction) {
  return conjugate_gradient([&](const Eigen::VectorXd& in, Eigen::VectorXd& out) { symmetric_product(A, in, out); },
                            b, x, precondition, tolerance, max_iterations, residual_reduction);
}

ConjugateGradientResult conjugate_gradient(const ApplyOperator& A, const Eigen::VectorXd& b, Eigen::VectorXd& x,
                                           const ApplyPreconditioner& precondition, double tolerance,
                                           int max_iterations, double residual_reduction) {
  ConjugateGradientResult result;
  const double b_norm2 = b.squaredNorm();
  if (b_norm2 == 0.0) {
    x.setZero();
    result.converged = true;
    return result;
  }
  double threshold = tolerance * tolerance * b_norm2;
  Eigen::VectorXd r(b.size()), z(b.size()), p(b.size()), Ap(b.size());
  A(x, Ap);
  r = b - Ap;
  if (residual_reduction < 1.0) {
    threshold = std::min(threshold, residual_reduction * residual_reduction * r.squaredNorm());
  }
  if (r.squaredNorm() <= threshold) {
    result.converged = true;
    return result;
  }
  precondition(r, z);
  p = z;
  double rz = r.dot(z);
  while (result.iterations < max_iterations) {
    A(p, Ap);
    const double pAp = p.dot(Ap);
    if (!(pAp > 0.0)) break;  // not positive definite, or a non-finite value: the caller checks x
    const double alpha = rz / pAp;
    x += alpha * p;
    r -= alpha * Ap;
    ++result.iterations;
    if (r.squaredNorm() <= threshold) {
      result.converged = true;
      break;
    }
    precondition(r, z);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
  return result;
}

}  // namespace fissure::sim
