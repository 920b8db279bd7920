#include "player/sim/loose_nodes.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdint>
#include <numeric>

#include "common/union_find.h"

namespace fissure::sim {

namespace {

/// A free node's 3-row block, kInvalidIndex for a pinned node.
Index block_of(const BlockSystem& system, NodeIndex node) {
  const Index row = system.row(node);
  return row == kInvalidIndex ? kInvalidIndex : row / 3;
}

/// Per free block: 1 if its node is in at most max_slots tets.
std::vector<std::uint8_t> few_slots(const BlockSystem& system, int max_slots) {
  std::vector<std::uint8_t> loose(system.free_count(), 0);
  for (Index b = 0; b < system.free_count(); ++b) {
    int slots = 0;
    system.for_each_slot(b, [&](TetIndex, int) { ++slots; });
    loose[b] = slots <= max_slots ? 1 : 0;
  }
  return loose;
}

/// Union-find parents over the free blocks: loose blocks that share a tet are joined.
std::vector<Index> join_through_tets(const Matrix4Xu& tets, const BlockSystem& system,
                                     const std::vector<std::uint8_t>& loose) {
  std::vector<Index> parent(system.free_count());
  std::iota(parent.begin(), parent.end(), Index{0});
  for (Eigen::Index t = 0; t < tets.cols(); ++t) {
    Index joined = kInvalidIndex;
    for (int c = 0; c < 4; ++c) {
      const Index b = block_of(system, tets(c, t));
      if (b == kInvalidIndex || loose[b] == 0) continue;
      const Index root = find_root(parent, b);
      if (joined != kInvalidIndex && root != joined) parent[std::max(root, joined)] = std::min(root, joined);
      joined = joined == kInvalidIndex ? root : std::min(root, joined);
    }
  }
  return parent;
}

}  // namespace

void LooseNodes::find(const Matrix4Xu& tets, const BlockSystem& system, int max_slots, int max_part_nodes) {
  m_parts.clear();
  m_loose_count = 0;
  const Index free_count = system.free_count();
  m_place.assign(free_count, kInvalidIndex);
  if (max_slots <= 0) return;
  std::vector<std::uint8_t> loose = few_slots(system, max_slots);
  std::vector<Index> parent = join_through_tets(tets, system, loose);
  std::vector<Index> size(free_count, 0);
  for (Index b = 0; b < free_count; ++b) size[find_root(parent, b)] += loose[b];
  std::vector<Index> part_of_root(free_count, kInvalidIndex);
  for (Index b = 0; b < free_count; ++b) {
    const Index root = find_root(parent, b);
    if (loose[b] == 0 || size[root] > static_cast<Index>(max_part_nodes)) {
      loose[b] = 0;
      continue;
    }
    if (part_of_root[root] == kInvalidIndex) {
      part_of_root[root] = static_cast<Index>(m_parts.size());
      m_parts.emplace_back();
    }
    Part& part = m_parts[part_of_root[root]];
    m_place[b] = static_cast<Index>(part.blocks.size());
    part.blocks.push_back(b);
    ++m_loose_count;
  }
  for (Eigen::Index t = 0; t < tets.cols(); ++t) {
    for (int c = 0; c < 4; ++c) {
      const Index b = block_of(system, tets(c, t));
      if (b == kInvalidIndex || loose[b] == 0) continue;
      m_parts[part_of_root[find_root(parent, b)]].tets.push_back(static_cast<TetIndex>(t));
      break;
    }
  }
}

void LooseNodes::update(const CorotatedElasticity& elasticity, const ElementBuffers& elements,
                        const Eigen::VectorXd& mass, const BlockSystem& system, double k_scale, double m_scale) {
  // Each part on its own: the same numbers on any thread count.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m_parts.size(), 16), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t p = r.begin(); p != r.end(); ++p) {
      update_part(m_parts[p], elasticity, elements, mass, system, k_scale, m_scale);
    }
  });
}

void LooseNodes::update_part(Part& part, const CorotatedElasticity& elasticity, const ElementBuffers& elements,
                             const Eigen::VectorXd& mass, const BlockSystem& system, double k_scale,
                             double m_scale) const {
  const auto rows = 3 * static_cast<Eigen::Index>(part.blocks.size());
  Eigen::MatrixXd loose = Eigen::MatrixXd::Zero(rows, rows);
  for (std::size_t i = 0; i < part.blocks.size(); ++i) {
    const auto r = 3 * static_cast<Eigen::Index>(i);
    loose.block<3, 3>(r, r) += m_scale * mass[system.free_node(part.blocks[i])] * Mat3::Identity();
  }
  part.couplings.clear();
  const Matrix4Xu& tets = elasticity.tets();
  for (const TetIndex t : part.tets) {
    for (int i = 0; i < 4; ++i) {
      const Index block_i = block_of(system, tets(i, t));
      if (block_i == kInvalidIndex || m_place[block_i] == kInvalidIndex) continue;
      const Index a = m_place[block_i];
      for (int j = 0; j < 4; ++j) {
        const Index block_j = block_of(system, tets(j, t));
        if (block_j == kInvalidIndex) continue;
        const Mat3 term = -k_scale * BlockSystem::tet_stiffness_block(t, i, j, elasticity, elements);
        const Index b = m_place[block_j];
        if (b == kInvalidIndex) {
          part.couplings.push_back({a, block_j, term});
        } else {
          loose.block<3, 3>(3 * static_cast<Eigen::Index>(a), 3 * static_cast<Eigen::Index>(b)) += term;
        }
      }
    }
  }
  part.loose.compute(loose);
  // A_ll is a principal block of a positive-definite A: only rounding can fail it, and
  // then the part's rows are left to the lagged factor for this step.
  part.factored = part.loose.info() == Eigen::Success;
}

void LooseNodes::eliminate(const Eigen::VectorXd& r) {
  m_core_residual = r;
  for (Part& part : m_parts) {
    if (!part.factored) continue;
    part.answer.resize(3 * static_cast<Eigen::Index>(part.blocks.size()));
    for (std::size_t i = 0; i < part.blocks.size(); ++i) {
      const auto row = 3 * static_cast<Eigen::Index>(part.blocks[i]);
      part.answer.segment<3>(3 * static_cast<Eigen::Index>(i)) = r.segment<3>(row);
      m_core_residual.segment<3>(row).setZero();
    }
    part.loose.solveInPlace(part.answer);
    for (const Coupling& c : part.couplings) {
      m_core_residual.segment<3>(3 * static_cast<Eigen::Index>(c.core)) -=
          c.block.transpose() * part.answer.segment<3>(3 * static_cast<Eigen::Index>(c.place));
    }
  }
}

void LooseNodes::back_substitute(Eigen::VectorXd& z) {
  for (Part& part : m_parts) {
    if (!part.factored) continue;
    part.pull.setZero(part.answer.size());
    for (const Coupling& c : part.couplings) {
      part.pull.segment<3>(3 * static_cast<Eigen::Index>(c.place)) += c.block * z.segment<3>(3 * static_cast<Eigen::Index>(c.core));
    }
    if (!part.couplings.empty()) part.loose.solveInPlace(part.pull);
    for (std::size_t i = 0; i < part.blocks.size(); ++i) {
      const auto local = 3 * static_cast<Eigen::Index>(i);
      z.segment<3>(3 * static_cast<Eigen::Index>(part.blocks[i])) = part.answer.segment<3>(local) - part.pull.segment<3>(local);
    }
  }
}

}  // namespace fissure::sim
