#pragma once
/// Diagonal blocks of a symmetric positive-definite operator over groups of nodes too
/// large to be dense (BlockJacobi), each kept in the sparsity of its terms, factored by
/// sparse Cholesky and solved exactly. The contact response uses one per large fragment:
/// its body's system on the fragment plus the terms of the fragment's contacts, which
/// the body's own preconditioner cannot see (contact_response.cpp).

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <Eigen/Sparse>

#include "common/types.h"
#include "player/sim/block_jacobi.h"
#include "player/sim/sparse_cholesky.h"

namespace fissure::sim {

class SparseBlocks {
 public:
  using OuterRows = BlockJacobi::OuterRows;

  SparseBlocks();
  ~SparseBlocks();
  SparseBlocks(const SparseBlocks&) = delete;
  SparseBlocks& operator=(const SparseBlocks&) = delete;

  /// `groups[g]` lists the first rows (multiples of 3) of group g's nodes in an operator
  /// of `size` rows. A row is in at most one group; rows in none are left to the caller.
  void set_groups(std::vector<std::vector<Eigen::Index>> groups, Eigen::Index size);
  [[nodiscard]] bool covers(Eigen::Index row) const { return m_node[row / 3].group != kNone; }
  [[nodiscard]] bool empty() const { return m_groups.empty(); }

  /// Adds `term` to the 3×3 block (row_a, row_b) of the base if both rows are in one
  /// group; otherwise it is outside every block and dropped. Only before
  /// set_outer_rows(), which fixes the pattern.
  void add(Eigen::Index row_a, Eigen::Index row_b, const Mat3& term);
  /// Ends the set-up: finds the pairs e, f of each term's rows that fall in one group
  /// (for a G that takes Σₑ wₑ x(rows[e])), whose blocks join the pattern, and analyses
  /// each group's pattern once.
  void set_outer_rows(std::span<const OuterRows> terms);
  /// Each block is its base plus wₑ w_f terms[k] at (rows[e], rows[f]) for every such
  /// pair of term k, summed in term order; then factored. A block that is not positive
  /// definite (short of rounding it cannot be) is replaced by its diagonal. `terms`
  /// matches the last set_outer_rows(). With `keep_large` set, a block over
  /// kKeptFactorNodes nodes that is already factored keeps its factor (now stale).
  void set_outer_terms(std::span<const Mat3> terms, bool keep_large = false);
  /// Blocks larger than this may keep a stale factor (set_outer_terms): on the bunny's
  /// piles a fragment of 600-1,300 nodes took 3-7 ms to factor, 45 % of the response
  /// when repeated every outer iteration; kept, the pile's collision phase took 16-38 %
  /// less time for 20-45 % more CG iterations (docs/decisions/0025-sparse-blocks-for-large-fragments.md).
  /// On a 98-node slab the stale factor doubled the CG iterations, which cost more than
  /// its cheap factorizations.
  static constexpr std::size_t kKeptFactorNodes = 256;
  /// z = block⁻¹ r on the covered rows; the other rows of z are left as they are.
  void solve(const Eigen::VectorXd& r, Eigen::VectorXd& z) const;

 private:
  static constexpr Index kNone = kInvalidIndex;
  struct Group;
  struct Node {
    Index group = kNone;
    Index local = 0;  ///< the node's place in its group
  };
  std::vector<Node> m_node;  ///< per node (row / 3)
  std::vector<std::unique_ptr<Group>> m_groups;
};

}  // namespace fissure::sim
