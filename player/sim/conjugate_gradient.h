#pragma once
/// Preconditioned conjugate gradients for the implicit step's symmetric positive-definite
/// system, with a parallel, deterministic product (each row is one task's dot product,
/// so the result does not depend on the thread count).

#include <Eigen/Sparse>
#include <functional>

namespace fissure::sim {

/// y = A x for a symmetric A stored with both triangles (column j is row j).
void symmetric_product(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& x, Eigen::VectorXd& y);

struct ConjugateGradientResult {
  int iterations = 0;
  bool converged = false;
};

/// z = P⁻¹ r.
using ApplyPreconditioner = std::function<void(const Eigen::VectorXd& r, Eigen::VectorXd& z)>;
/// y = A x, for a system that is never assembled (a matrix-free product).
using ApplyOperator = std::function<void(const Eigen::VectorXd& x, Eigen::VectorXd& y)>;

/// Solves A x = b from the initial guess in x until ‖b − A x‖ ≤ tolerance ‖b‖ or
/// max_iterations. b = 0 gives x = 0. With residual_reduction in (0, 1) it also goes on
/// until the residual is at most that share of the initial guess's, so a guess already
/// within tolerance ‖b‖ is still improved (a warm-started inner solve of an outer
/// iteration); 1 leaves the rule as it was.
ConjugateGradientResult conjugate_gradient(const ApplyOperator& A, const Eigen::VectorXd& b, Eigen::VectorXd& x,
                                           const ApplyPreconditioner& precondition, double tolerance,
                                           int max_iterations, double residual_reduction = 1.0);
/// The same with an assembled A (symmetric_product).
ConjugateGradientResult conjugate_gradient(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& b,
                                           Eigen::VectorXd& x, const ApplyPreconditioner& precondition,
                                           double tolerance, int max_iterations, double residual_reduction = 1.0);

}  // namespace fissure::sim
