#pragma once
/// Sparse Cholesky factorization A = L Lᵀ of a symmetric positive-definite matrix
/// (CHOLMOD's supernodal method, so the factorization's dense kernels run in BLAS). The
/// symbolic analysis (fill-reducing ordering, supernodes) is kept until the sparsity
/// pattern changes; factorize() then only recomputes the numbers. CHOLMOD stays out of
/// this header.
///
/// The triangular solves are our own, over CHOLMOD's supernodes, in one of two
/// precisions:
///  - Double: the factor as computed; for the direct solver.
///  - Single: the factor's values rounded to float, with the arithmetic still in
///    double. The solves read every value of L twice, and at 10k tets L has ~1M values,
///    so they are bound by memory traffic, which this halves. The result is the exact
///    inverse of a nearby matrix L̃ L̃ᵀ (still symmetric positive definite), which is
///    all a preconditioner needs.
///
/// A large factor's solves run on two threads: two groups of disjoint subtrees of the
/// elimination tree are swept at once, their common ancestors alone. The summation
/// order is fixed by the factor, so the result does not depend on the thread count.

#include <Eigen/Sparse>
#include <memory>

namespace fissure::sim {

enum class FactorPrecision { Double, Single };

class SparseCholesky {
 public:
  SparseCholesky();
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  /// Orders and analyses A's pattern (both triangles stored; the lower one is read).
  void analyze(const Eigen::SparseMatrix<double>& A);
  [[nodiscard]] bool analyzed() const;
  /// Numeric factorization with the analysed pattern; solve() will use `precision`.
  /// False if A is not positive definite.
  [[nodiscard]] bool factorize(const Eigen::SparseMatrix<double>& A,
                               FactorPrecision precision = FactorPrecision::Double);
  [[nodiscard]] bool factorized() const { return m_factorized; }
  /// x = A⁻¹ b with the last factorization (in the precision it was made for).
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const;
  /// Forgets the factorization and the analysis (the pattern changed).
  void reset();
  /// Whether solve() splits its sweeps over two threads (large factors only).
  [[nodiscard]] bool solves_on_two_threads() const;
  /// Nonzeros of L (including its diagonal), known once analyze() has run.
  [[nodiscard]] std::size_t factor_nonzeros() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
  bool m_factorized = false;
};

}  // namespace fissure::sim
