#pragma once
/// Sparse Cholesky factorization A = L Lᵀ of a symmetric positive-definite matrix
/// (CHOLMOD's supernodal method, so dense kernels run in BLAS). The symbolic analysis
/// (fill-reducing ordering, supernodes) is kept until the sparsity pattern changes;
/// factorize() then only recomputes the numbers. CHOLMOD stays out of this header.

#include <Eigen/Sparse>
#include <memory>

namespace fissure::sim {

class SparseCholesky {
 public:
  SparseCholesky();
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  /// Orders and analyses A's pattern (both triangles stored; the lower one is read).
  void analyze(const Eigen::SparseMatrix<double>& A);
  [[nodiscard]] bool analyzed() const;
  /// Numeric factorization with the analysed pattern. False if A is not positive definite.
  [[nodiscard]] bool factorize(const Eigen::SparseMatrix<double>& A);
  [[nodiscard]] bool factorized() const { return m_factorized; }
  /// x = A⁻¹ b with the last factorization.
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const;
  /// Forgets the factorization and the analysis (the pattern changed).
  void reset();

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
  bool m_factorized = false;
};

}  // namespace fissure::sim
