// SparseCholesky without CHOLMOD (FISSURE_WITH_CHOLMOD=OFF): Eigen's simplicial LLᵀ
// with an AMD ordering. Everything Eigen does is MPL-2.0, so a player built this way
// links no GPL code of SuiteSparse (docs/licensing.md). It is slower on large cages (no
// supernodes, so no BLAS-3 kernels; docs/decisions/0014-own-supernodal-solves.md),
// solves in double whatever the precision asked (a preconditioner loses nothing by it
// but memory traffic), and on one thread. The interface and its guarantees are
// sparse_cholesky.h's.
#include <Eigen/SparseCholesky>

#include "common/assert.h"
#include "player/sim/sparse_cholesky.h"

namespace fissure::sim {

struct SparseCholesky::Impl {
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> llt;
  bool analyzed = false;
};

SparseCholesky::SparseCholesky() : m_impl(std::make_unique<Impl>()) {}
SparseCholesky::~SparseCholesky() = default;

void SparseCholesky::analyze(const Eigen::SparseMatrix<double>& A) {
  reset();
  m_impl->llt.analyzePattern(A);
  m_impl->analyzed = true;
}

bool SparseCholesky::analyzed() const { return m_impl->analyzed; }

bool SparseCholesky::factorize(const Eigen::SparseMatrix<double>& A, FactorPrecision /*precision*/) {
  FISSURE_ASSERT(analyzed());
  m_impl->llt.factorize(A);
  m_factorized = m_impl->llt.info() == Eigen::Success;
  return m_factorized;
}

void SparseCholesky::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const {
  FISSURE_ASSERT(m_factorized);
  x = m_impl->llt.solve(b);
}

void SparseCholesky::reset() {
  m_impl = std::make_unique<Impl>();
  m_factorized = false;
}

bool SparseCholesky::solves_on_two_threads() const { return false; }

std::size_t SparseCholesky::factor_nonzeros() const {
  // Known from the analysis: the elimination tree's column counts.
  return m_impl->analyzed ? static_cast<std::size_t>(m_impl->llt.matrixL().nestedExpression().nonZeros()) : 0;
}

}  // namespace fissure::sim
