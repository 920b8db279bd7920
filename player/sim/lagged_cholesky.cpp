#include "player/sim/lagged_cholesky.h"

#include <tbb/blocked_range.h>

#include "player/sim/lanes.h"

namespace fissure::sim {

namespace {

/// From this many factor entries the lagged preconditioner keeps its factor in float:
/// its solves are then bound by memory traffic, which float halves. A smaller factor
/// sits in cache, and float would only cost iterations on the ill-conditioned matrices
/// of a fractured cage (measured on the bunny scene, 987 tets: 62 → 97 refactorizations
/// and a 1.2–1.3× slower solve phase).
constexpr std::size_t kSinglePrecisionMinFactorEntries = 200'000;

}  // namespace

bool LaggedCholesky::factorize(const Eigen::SparseMatrix<double>& A, double k_scale, double m_scale,
                               const std::vector<Mat3>& rotations, bool allow_single) {
  if (!m_cholesky.analyzed()) m_cholesky.analyze(A);
  m_k_scale = k_scale;
  m_m_scale = m_scale;
  m_factored_rotations = rotations;
  const bool single = allow_single && m_cholesky.factor_nonzeros() >= kSinglePrecisionMinFactorEntries;
  return m_cholesky.factorize(A, single ? FactorPrecision::Single : FactorPrecision::Double);
}

void LaggedCholesky::follow_rotations(const std::vector<Mat3>& rotations, const BlockSystem& system) {
  // Each tet's rotation change once (a node has ~16 tets), then per node their sum.
  const std::size_t tet_count = rotations.size();
  m_tet_rotation_change.resize(tet_count);
  parallel_for_range<std::size_t>(tet_count, 1024, [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t t = r.begin(); t != r.end(); ++t) {
      m_tet_rotation_change[t].noalias() = rotations[t] * m_factored_rotations[t].transpose();
    }
  });
  const Index free_count = system.free_count();
  m_node_rotation.resize(free_count);
  parallel_for_batches<Index>(free_count, 256, [&](Index first, int size) {
    Mat3 sums[kLanes];
    for (int l = 0; l < size; ++l) {
      sums[l].setZero();
      system.for_each_slot(first + l, [&](TetIndex t, int /*corner*/) { sums[l] += m_tet_rotation_change[t]; });
    }
    polar_rotations(sums, &m_node_rotation[first], size);
  });
}

void LaggedCholesky::rotated_solve(const Eigen::VectorXd& r, Eigen::VectorXd& z) const {
  const auto free_count = static_cast<Index>(m_node_rotation.size());
  Eigen::VectorXd rotated(r.size());
  for (Index c = 0; c < free_count; ++c) rotated.segment<3>(3 * c) = m_node_rotation[c].transpose() * r.segment<3>(3 * c);
  m_cholesky.solve(rotated, z);
  for (Index c = 0; c < free_count; ++c) z.segment<3>(3 * c) = m_node_rotation[c] * z.segment<3>(3 * c).eval();
}

}  // namespace fissure::sim
