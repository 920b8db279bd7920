#include "player/sim/sparse_blocks.h"

#include <algorithm>
#include <limits>
#include <unordered_map>
#include <utility>

#include "common/assert.h"

namespace fissure::sim {

struct SparseBlocks::Group {
  std::vector<Eigen::Index> rows;  ///< the first rows of its nodes
  /// Its 3×3 blocks ("slots"): where each sits (local nodes a, b) and its base value.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> places;
  std::vector<Mat3> base, value;
  std::unordered_map<std::uint64_t, std::uint32_t> slot_of;  ///< (a, b) → slot; the set-up's
  /// One pair of a term's rows inside the group: weight · terms[term] goes to `slot`.
  struct Pair {
    std::uint32_t term, slot;
    double weight;
  };
  std::vector<Pair> pairs;
  Eigen::SparseMatrix<double> matrix;
  std::vector<Eigen::Index> value_index;  ///< slot s's entry (i, j): matrix.valuePtr()[value_index[9 s + 3 i + j]]
  SparseCholesky factor;
  Eigen::VectorXd inverse_diagonal;  ///< the fallback where the block is not positive definite

  std::uint32_t slot(Index a, Index b) {
    const std::uint64_t key = (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint64_t>(b);
    const auto [found, added] = slot_of.try_emplace(key, static_cast<std::uint32_t>(places.size()));
    if (added) {
      places.emplace_back(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b));
      base.push_back(Mat3::Zero());
    }
    return found->second;
  }

  /// The matrix's pattern from the slots, each entry's place in it, and its analysis.
  void build_pattern() {
    std::vector<Eigen::Triplet<double>> entries;
    entries.reserve(9 * places.size());
    for (std::size_t s = 0; s < places.size(); ++s) {
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
          // Each entry's own number, exact in a double: setFromTriplets places it.
          entries.emplace_back(3 * places[s].first + i, 3 * places[s].second + j, static_cast<double>(9 * s + 3 * i + j));
        }
      }
    }
    const auto n = 3 * static_cast<Eigen::Index>(rows.size());
    matrix.resize(n, n);
    matrix.setFromTriplets(entries.begin(), entries.end());
    value_index.assign(entries.size(), 0);
    for (Eigen::Index k = 0; k < matrix.nonZeros(); ++k) {
      value_index[static_cast<std::size_t>(matrix.valuePtr()[k])] = k;
    }
    factor.reset();
    factor.analyze(matrix);
    slot_of.clear();
  }

  void set_values(std::span<const Mat3> terms) {
    value = base;
    for (const Pair& p : pairs) {
      FISSURE_ASSERT(p.term < terms.size());
      value[p.slot] += p.weight * terms[p.term];
    }
    double* values = matrix.valuePtr();
    for (std::size_t s = 0; s < value.size(); ++s) {
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) values[value_index[9 * s + 3 * i + j]] = value[s](i, j);
      }
    }
    if (factor.factorize(matrix)) {
      inverse_diagonal.resize(0);
    } else {
      inverse_diagonal = matrix.diagonal().cwiseMax(1e-300).cwiseInverse();
    }
  }
};

SparseBlocks::SparseBlocks() = default;
SparseBlocks::~SparseBlocks() = default;

void SparseBlocks::set_groups(std::vector<std::vector<Eigen::Index>> groups, Eigen::Index size) {
  m_node.assign(static_cast<std::size_t>(size / 3), Node{});
  m_groups.clear();
  for (std::vector<Eigen::Index>& rows : groups) {
    const auto g = static_cast<Index>(m_groups.size());
    FISSURE_ASSERT(rows.size() < std::numeric_limits<std::uint32_t>::max());
    for (std::size_t local = 0; local < rows.size(); ++local) {
      FISSURE_ASSERT(rows[local] % 3 == 0 && m_node[rows[local] / 3].group == kNone);
      m_node[rows[local] / 3] = {g, static_cast<Index>(local)};
    }
    m_groups.push_back(std::make_unique<Group>());
    m_groups.back()->rows = std::move(rows);
  }
}

void SparseBlocks::add(Eigen::Index row_a, Eigen::Index row_b, const Mat3& term) {
  const Node &a = m_node[row_a / 3], &b = m_node[row_b / 3];
  if (a.group == kNone || a.group != b.group) return;
  Group& g = *m_groups[a.group];
  FISSURE_ASSERT(g.value_index.empty());  // the pattern is not fixed yet
  g.base[g.slot(a.local, b.local)] += term;
}

void SparseBlocks::set_outer_rows(std::span<const OuterRows> terms) {
  FISSURE_ASSERT(terms.size() <= std::numeric_limits<std::uint32_t>::max());
  for (auto& g : m_groups) g->pairs.clear();
  for (std::size_t k = 0; k < terms.size(); ++k) {
    const OuterRows& term = terms[k];
    const auto count = static_cast<std::size_t>(std::clamp(term.count, 0, 8));
    for (std::size_t e = 0; e < count; ++e) {
      const Node& a = m_node[term.rows[e] / 3];
      if (a.group == kNone) continue;
      for (std::size_t f = 0; f < count; ++f) {
        const Node& b = m_node[term.rows[f] / 3];
        if (b.group != a.group) continue;
        Group& g = *m_groups[a.group];
        g.pairs.push_back({static_cast<std::uint32_t>(k), g.slot(a.local, b.local), term.weights[e] * term.weights[f]});
      }
    }
  }
  for (auto& g : m_groups) g->build_pattern();
}

void SparseBlocks::set_outer_terms(std::span<const Mat3> terms, bool keep_large) {
  for (auto& g : m_groups) {
    const bool factored = g->factor.factorized() || g->inverse_diagonal.size() > 0;
    if (keep_large && factored && g->rows.size() > kKeptFactorNodes) continue;
    g->set_values(terms);
  }
}

void SparseBlocks::solve(const Eigen::VectorXd& r, Eigen::VectorXd& z) const {
  Eigen::VectorXd local, answer;
  for (const auto& g : m_groups) {
    const std::vector<Eigen::Index>& rows = g->rows;
    local.resize(3 * static_cast<Eigen::Index>(rows.size()));
    for (std::size_t k = 0; k < rows.size(); ++k) local.segment<3>(3 * static_cast<Eigen::Index>(k)) = r.segment<3>(rows[k]);
    if (g->inverse_diagonal.size() > 0) {
      answer = g->inverse_diagonal.cwiseProduct(local);
    } else {
      g->factor.solve(local, answer);
    }
    for (std::size_t k = 0; k < rows.size(); ++k) z.segment<3>(rows[k]) = answer.segment<3>(3 * static_cast<Eigen::Index>(k));
  }
}

}  // namespace fissure::sim
