#include "player/sim/block_jacobi.h"

#include <algorithm>
#include <array>
#include <limits>
#include <type_traits>

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
    FISSURE_ASSERT(rows.size() <= std::numeric_limits<std::uint16_t>::max());  // OuterPair's places
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
  const Slot &a = m_slot[row_a / 3], &b = m_slot[row_b / 3];
  if (a.group == kNone || a.group != b.group || a.fixed != b.fixed) return;
  if (a.fixed) {
    m_fixed.block[a.group].block<3, 3>(3 * a.local, 3 * b.local) += term;
  } else {
    m_dynamic.block[a.group].block<3, 3>(3 * a.local, 3 * b.local) += term;
  }
}

template <typename F>
void BlockJacobi::for_each_outer_pair(std::span<const OuterRows> terms, F&& visit) const {
  for (std::size_t k = 0; k < terms.size(); ++k) {
    const OuterRows& term = terms[k];
    FISSURE_ASSERT(term.count >= 0 && term.count <= 8);
    const auto count = static_cast<std::size_t>(std::clamp(term.count, 0, 8));
    std::array<Slot, 8> slots;
    for (std::size_t e = 0; e < count; ++e) slots[e] = m_slot[term.rows[e] / 3];
    for (std::size_t e = 0; e < count; ++e) {
      if (slots[e].group == kNone) continue;
      for (std::size_t f = 0; f < count; ++f) {
        if (slots[f].group == slots[e].group && slots[f].fixed == slots[e].fixed) {
          visit(k, slots[e], slots[f], term.weights[e] * term.weights[f]);
        }
      }
    }
  }
}

void BlockJacobi::set_outer_rows(std::span<const OuterRows> terms) {
  FISSURE_ASSERT(terms.size() <= std::numeric_limits<std::uint32_t>::max());
  for_each_set([](auto& set) { set.pair_start.assign(set.rows.size() + 1, 0); });
  for_each_outer_pair(terms, [&](std::size_t, const Slot& a, const Slot&, double) {
    ++(a.fixed ? m_fixed.pair_start : m_dynamic.pair_start)[a.group + 1];
  });
  for_each_set([](auto& set) {
    for (std::size_t g = 0; g + 1 < set.pair_start.size(); ++g) set.pair_start[g + 1] += set.pair_start[g];
    set.pairs.resize(set.pair_start.back());
  });
  std::vector<std::size_t> fixed_next(m_fixed.pair_start.begin(), m_fixed.pair_start.end() - 1);
  std::vector<std::size_t> dynamic_next(m_dynamic.pair_start.begin(), m_dynamic.pair_start.end() - 1);
  for_each_outer_pair(terms, [&](std::size_t k, const Slot& a, const Slot& b, double weight) {
    auto& set_pairs = a.fixed ? m_fixed.pairs : m_dynamic.pairs;
    std::size_t& next = (a.fixed ? fixed_next : dynamic_next)[a.group];
    set_pairs[next++] = {static_cast<std::uint32_t>(k), static_cast<std::uint16_t>(a.local),
                         static_cast<std::uint16_t>(b.local), weight};
  });
}

void BlockJacobi::set_outer_terms(std::span<const Mat3> terms) {
  for_each_set([&](auto& set) {
    constexpr bool kFixed = std::remove_reference_t<decltype(set)>::Matrix::RowsAtCompileTime != Eigen::Dynamic;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, set.rows.size(), kFixed ? kGroupsPerTask : 1),
                      [&](const tbb::blocked_range<std::size_t>& range) {
      for (std::size_t g = range.begin(); g != range.end(); ++g) {
        set.block[g] = set.base[g];
        for (std::size_t p = set.pair_start[g]; p < set.pair_start[g + 1]; ++p) {
          const OuterPair& pair = set.pairs[p];
          FISSURE_ASSERT(pair.term < terms.size());
          set.block[g].template block<3, 3>(3 * pair.a, 3 * pair.b) += pair.weight * terms[pair.term];
        }
      }
    });
  });
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

Index BlockJacobi::group_of(Eigen::Index row) const {
  const Slot& slot = m_slot[row / 3];
  if (slot.group == kNone) return kNone;
  return slot.fixed ? slot.group : static_cast<Index>(m_fixed.rows.size()) + slot.group;
}

const std::vector<Eigen::Index>& BlockJacobi::group_rows(Index group) const {
  const auto fixed_groups = static_cast<Index>(m_fixed.rows.size());
  return group < fixed_groups ? m_fixed.rows[group] : m_dynamic.rows[group - fixed_groups];
}

void BlockJacobi::solve_group(Index group, Eigen::Ref<const Eigen::MatrixXd> r, Eigen::Ref<Eigen::MatrixXd> z) const {
  const auto fixed_groups = static_cast<Index>(m_fixed.rows.size());
  if (group < fixed_groups) {
    // The padding is the identity and decoupled, so the inverse's corner is the block's.
    // A lazy product: at 12 × 3 the blocked kernel's set-up costs more than the flops.
    const Eigen::Index n = r.rows();
    z.noalias() = m_fixed.inverse[group].topLeftCorner(n, n).lazyProduct(r);
  } else {
    z = m_dynamic.factors[group - fixed_groups].solve(r);
  }
}

}  // namespace fissure::sim
