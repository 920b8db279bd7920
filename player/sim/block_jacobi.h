#pragma once
/// Dense diagonal blocks of a symmetric positive-definite operator over groups of nodes
/// (three rows each), each factored and solved exactly: a block-Jacobi preconditioner
/// for the rows the groups cover. The contact response uses one group per small
/// fragment and per projectile, with the contacts' terms inside the group added, which
/// the bodies' own preconditioners cannot see (contact_response.cpp).

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Cholesky>

#include "common/types.h"

namespace fissure::sim {

class BlockJacobi {
 public:
  /// `groups[g]` lists the first rows (multiples of 3) of group g's nodes in an operator
  /// of `size` rows. A row is in at most one group; rows in none are left to the caller.
  void set_groups(std::vector<std::vector<Eigen::Index>> groups, Eigen::Index size);
  [[nodiscard]] bool covers(Eigen::Index row) const { return m_slot[row / 3].group != kNone; }

  /// Adds `term` to the 3×3 block (row_a, row_b) if both rows are in one group;
  /// otherwise it is outside every block and dropped.
  void add(Eigen::Index row_a, Eigen::Index row_b, const Mat3& term);
  /// Keeps the blocks as they are now, as what reset() returns to.
  void keep_as_base();
  /// Back to the blocks as kept by keep_as_base().
  void reset();

  /// The rows of a term Gᵀ T G, for a G that takes Σₑ wₑ x(rows[e]).
  struct OuterRows {
    std::array<Eigen::Index, 8> rows{};
    std::array<double, 8> weights{};
    int count = 0;
  };
  /// Finds, once, the pairs e, f of each term's rows that fall in one group, listed per
  /// group, so that set_outer_terms() can add many terms' blocks in parallel.
  void set_outer_rows(std::span<const OuterRows> terms);
  /// reset(), then adds wₑ w_f terms[k] to the block (rows[e], rows[f]) of every such
  /// pair of term k (Gₖᵀ Tₖ Gₖ where it falls inside the blocks), as add() would pair by
  /// pair. Each group sums its terms in their order, so the blocks do not depend on the
  /// thread count. `terms` matches the last set_outer_rows().
  void set_outer_terms(std::span<const Mat3> terms);
  /// Inverts every block. A block that is not positive definite (it cannot be from a
  /// positive-definite operator, short of rounding) is replaced by its diagonal.
  void factor();
  /// z = block⁻¹ r on the covered rows; the other rows of z are left as they are.
  void solve(const Eigen::VectorXd& r, Eigen::VectorXd& z) const;

  /// The groups one at a time, numbered 0 … group_count() − 1 (the order is this
  /// class's, not set_groups()'s), for a caller that works on one group's rows alone:
  /// the sequential-impulse response (sequential_impulses.h).
  [[nodiscard]] Index group_count() const { return static_cast<Index>(m_fixed.rows.size() + m_dynamic.rows.size()); }
  /// The group that covers `row`, or kInvalidIndex.
  [[nodiscard]] Index group_of(Eigen::Index row) const;
  /// `row`'s node's place in its group: its rows are [3 place, 3 place + 3) of the group's.
  [[nodiscard]] Index place_in_group(Eigen::Index row) const { return m_slot[row / 3].local; }
  /// The first rows of the group's nodes, in its order.
  [[nodiscard]] const std::vector<Eigen::Index>& group_rows(Index group) const;
  /// z = block⁻¹ r for one group, on its 3 × nodes rows (any number of columns).
  void solve_group(Index group, Eigen::Ref<const Eigen::MatrixXd> r, Eigen::Ref<Eigen::MatrixXd> z) const;

 private:
  static constexpr Index kNone = kInvalidIndex;
  /// Groups of at most 4 nodes (a one-tet fragment, a projectile) are kept in fixed
  /// 12×12 matrices, padded with the identity, with their inverses: a product with a
  /// fixed 12×12 inverse is several times faster than Eigen's triangular solves at that
  /// size, and a shattered body has hundreds of such groups. Larger groups keep their
  /// Cholesky factors (the inverse would cost twice the factor's n³/3 to make).
  static constexpr int kFixedNodes = 4;
  /// One pair of a term's rows inside a group: weight · terms[term] goes to the group's
  /// 3×3 block (a, b).
  struct OuterPair {
    std::uint32_t term;
    std::uint16_t a, b;
    double weight;
  };
  template <int N>
  struct Groups {
    using Matrix = Eigen::Matrix<double, N, N>;
    std::vector<std::vector<Eigen::Index>> rows;
    std::vector<Matrix> base, block;
    std::vector<Matrix> inverse;              ///< fixed-size groups
    std::vector<Eigen::LLT<Matrix>> factors;  ///< dynamic-size groups
    std::vector<std::size_t> pair_start;      ///< group g's pairs: [pair_start[g], pair_start[g + 1])
    std::vector<OuterPair> pairs;
  };
  struct Slot {
    Index group = kNone;  ///< in m_fixed if `fixed`, else in m_dynamic
    Index local = 0;      ///< the node's place in its group
    bool fixed = false;
  };
  /// visit(term, a, b, wₑ w_f) for every pair of a term's rows inside one group, in term order.
  template <typename F>
  void for_each_outer_pair(std::span<const OuterRows> terms, F&& visit) const;
  template <typename F>
  void for_each_set(F&& f) {
    f(m_fixed);
    f(m_dynamic);
  }
  std::vector<Slot> m_slot;  ///< per node (row / 3)
  Groups<3 * kFixedNodes> m_fixed;
  Groups<Eigen::Dynamic> m_dynamic;
};

}  // namespace fissure::sim
