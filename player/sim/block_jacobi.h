#pragma once
/// Dense diagonal blocks of a symmetric positive-definite operator over groups of nodes
/// (three rows each), each factored and solved exactly: a block-Jacobi preconditioner
/// for the rows the groups cover. The contact response uses one group per small
/// fragment and per projectile, with the contacts' terms inside the group added, which
/// the bodies' own preconditioners cannot see (contact_response.cpp).

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
  /// Adds wₑ w_f `term` to the block (rows[e], rows[f]) of every pair e, f in one group:
  /// Gᵀ T G for a G that takes Σₑ wₑ x(rows[e]), as add() would pair by pair.
  void add_outer(std::span<const Eigen::Index> rows, std::span<const double> weights, const Mat3& term);
  /// Keeps the blocks as they are now, as what reset() returns to.
  void keep_as_base();
  /// Back to the blocks as kept by keep_as_base().
  void reset();
  /// Inverts every block. A block that is not positive definite (it cannot be from a
  /// positive-definite operator, short of rounding) is replaced by its diagonal.
  void factor();
  /// z = block⁻¹ r on the covered rows; the other rows of z are left as they are.
  void solve(const Eigen::VectorXd& r, Eigen::VectorXd& z) const;

 private:
  static constexpr Index kNone = kInvalidIndex;
  /// Groups of at most 4 nodes (a one-tet fragment, a projectile) are kept in fixed
  /// 12×12 matrices, padded with the identity, with their inverses: a product with a
  /// fixed 12×12 inverse is several times faster than Eigen's triangular solves at that
  /// size, and a shattered body has hundreds of such groups. Larger groups keep their
  /// Cholesky factors (the inverse would cost twice the factor's n³/3 to make).
  static constexpr int kFixedNodes = 4;
  template <int N>
  struct Groups {
    using Matrix = Eigen::Matrix<double, N, N>;
    std::vector<std::vector<Eigen::Index>> rows;
    std::vector<Matrix> base, block;
    std::vector<Matrix> inverse;              ///< fixed-size groups
    std::vector<Eigen::LLT<Matrix>> factors;  ///< dynamic-size groups
  };
  struct Slot {
    Index group = kNone;  ///< in m_fixed if `fixed`, else in m_dynamic
    Index local = 0;      ///< the node's place in its group
    bool fixed = false;
  };
  /// Adds `term` to the block (a, b) if both slots are in one group.
  void accumulate(const Slot& a, const Slot& b, const Mat3& term);
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
