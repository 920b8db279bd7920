#include "player/sim/sparse_cholesky.h"

#include <Eigen/CholmodSupport>

namespace fissure::sim {

struct SparseCholesky::Impl {
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower> factor;
  bool analyzed = false;
};

SparseCholesky::SparseCholesky() : m_impl(std::make_unique<Impl>()) {}
SparseCholesky::~SparseCholesky() = default;

void SparseCholesky::analyze(const Eigen::SparseMatrix<double>& A) {
  m_impl->factor.analyzePattern(A);
  m_impl->analyzed = true;
  m_factorized = false;
}

bool SparseCholesky::analyzed() const { return m_impl->analyzed; }

bool SparseCholesky::factorize(const Eigen::SparseMatrix<double>& A) {
  m_impl->factor.factorize(A);
  m_factorized = m_impl->factor.info() == Eigen::Success;
  return m_factorized;
}

void SparseCholesky::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const { x = m_impl->factor.solve(b); }

void SparseCholesky::reset() {
  m_impl = std::make_unique<Impl>();
  m_factorized = false;
}

}  // namespace fissure::sim
