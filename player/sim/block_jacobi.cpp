#include "player/sim/block_jacobi.h"

#include <array>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/assert.h"

namespace fissure::sim {

namespace {

/// Fixed-size groups per task: each is a few microseconds of work.
constexpr std::size_t kGroupsPerTask = 64;

/// Zero blocks sized for `nodes` nodes; padded with the identity where the matrix is
/// larger (fixed-size groups), so the padding solves to itself and is never read.
template <typename Matrix>
Matrix empty_block(std::size_t nodes) {
  const Eigen::Index n = 3 * static_cast<Eigen::Index>(nodes);
  constexpr Eigen::Index kFixed = Matrix::RowsAtCompileTime;
  const Eigen::Index size = kFixed == Eigen::Dynamic ? n : kFixed;
  Matrix block = Matrix::Identity(size, size);
  block.topLeftCorner(n, n).setZero();
  return block;
}

/// Every group on its own (one writer per row of z), so in parallel and independent of
/// the thread count.
template <typename Set>
void solve_set(const Set& set, const Eigen::VectorXd& r, Eigen::VectorXd& z) {
  constexpr bool kFixed = Set::Matrix::RowsAtCompileTime != Eigen::Dynamic;
  using Vector = Eigen::Matrix<double, Set::Matrix::RowsAtCompileTime, 1>;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, set.rows.size(), kGroupsPerTask),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    Vector local, answer;
    for (std::size_t g = range.begin(); g != range.end(); ++g) {
      const std::vector<Eigen::Index>& rows = set.rows[g];
      local.setZero(set.block[g].rows());
      for (std::size_t k = 0; k < rows.size(); ++k) local.template segment<3>(3 * k) = r.segment<3>(rows[k]);
      if constexpr (kFixed) {
        answer.noalias() = set.inverse[g] * local;
      } else {
        answer = set.factors[g].solve(local);
      }
      for (std::size_t k = 0; k < rows.size(); ++k) z.segment<3>(rows[k]) = answer.template segment<3>(3 * k);
    }
  });
}

/// Its diagonal where a block is not positive definite.
template <typename Matrix>
Matrix diagonal_of(const Matrix& block) {
  return block.diagonal().cwiseMax(1e-300).asDiagonal();
}

}  // namespace

void BlockJacobi::set_groups(std::vector<std::vector<Eigen::Index>> groups, Eigen::Index size) {
  m_slot.assign(static_cast<std::size_t>(size / 3), Slot{});
  m_fixed = {};
  m_dynamic = {};
  const auto place = [&](auto& set, std::vector<Eigen::Index>&& rows, bool fixed) {
    using Matrix = typename std::remove_reference_t<decltype(set)>::Matrix;
    const auto g = static_cast<Index>(set.rows.size());
    for (std::size_t local = 0; local < rows.size(); ++local) {
      FISSURE_ASSERT(rows[local] % 3 == 0 && m_slot[rows[local] / 3].group == kNone);
      m_slot[rows[local] / 3] = {g, static_cast<Index>(local), fixed};
    }
    set.block.push_back(empty_block<Matrix>(rows.size()));
    set.rows.push_back(std::move(rows));
  };
  for (std::vector<Eigen::Index>& rows : groups) {
    if (rows.size() <= kFixedNodes) {
      place(m_fixed, std::move(rows), true);
    } else {
      place(m_dynamic, std::move(rows), false);
    }
  }
  m_fixed.inverse.resize(m_fixed.rows.size());
  m_dynamic.factors.resize(m_dynamic.rows.size());
}

void BlockJacobi::add(Eigen::Index row_a, Eigen::Index row_b, const Mat3& term) {
  accumulate(m_slot[row_a / 3], m_slot[row_b / 3], term);
}

void BlockJacobi::add_outer(std::span<const Eigen::Index> rows, std::span<const double> weights, const Mat3& term) {
  FISSURE_ASSERT(rows.size() == weights.size() && rows.size() <= 8);
  std::array<Slot, 8> slots;
  for (std::size_t e = 0; e < rows.size(); ++e) slots[e] = m_slot[rows[e] / 3];
  for (std::size_t e = 0; e < rows.size(); ++e) {
    if (slots[e].group == kNone) continue;
    for (std::size_t f = 0; f < rows.size(); ++f) {
      if (slots[f].group == slots[e].group && slots[f].fixed == slots[e].fixed) {
        accumulate(slots[e], slots[f], weights[e] * weights[f] * term);
      }
    }
  }
}

void BlockJacobi::accumulate(const Slot& a, const Slot& b, const Mat3& term) {
  if (a.group == kNone || a.group != b.group || a.fixed != b.fixed) return;
  if (a.fixed) {
    m_fixed.block[a.group].block<3, 3>(3 * a.local, 3 * b.local) += term;
  } else {
    m_dynamic.block[a.group].block<3, 3>(3 * a.local, 3 * b.local) += term;
  }
}

void BlockJacobi::keep_as_base() {
  for_each_set([](auto& set) { set.base = set.block; });
}

void BlockJacobi::reset() {
  for_each_set([](auto& set) { set.block = set.base; });
}

void BlockJacobi::factor() {
  using Fixed = decltype(m_fixed)::Matrix;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m_fixed.block.size(), kGroupsPerTask),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t g = range.begin(); g != range.end(); ++g) {
      Eigen::LLT<Fixed> factor(m_fixed.block[g]);
      if (factor.info() != Eigen::Success) factor.compute(diagonal_of(m_fixed.block[g]));
      m_fixed.inverse[g] = factor.solve(Fixed::Identity());
    }
  });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m_dynamic.block.size(), 1),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t g = range.begin(); g != range.end(); ++g) {
      m_dynamic.factors[g].compute(m_dynamic.block[g]);
      if (m_dynamic.factors[g].info() != Eigen::Success) m_dynamic.factors[g].compute(diagonal_of(m_dynamic.block[g]));
    }
  });
}

void BlockJacobi::solve(const Eigen::VectorXd& r, Eigen::VectorXd& z) const {
  solve_set(m_fixed, r, z);
  solve_set(m_dynamic, r, z);
}

}  // namespace fissure::sim
