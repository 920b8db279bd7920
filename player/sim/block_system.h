#pragma once
/// The implicit step's system A = m_scale M − k_scale K in 3×3 blocks over a body's
/// free nodes: its sparsity pattern (built once, rebuilt only when a split or a pin
/// changes the connectivity), its assembly into that fixed pattern, and its product
/// element by element without the matrix (what conjugate gradients use between
/// factorizations).
///
/// Every sum runs in a fixed order — a block's terms in tet order, a node's (tet,
/// corner) slots in tet order — and every output has one writer, so the results do
/// not depend on the thread count.

#include <Eigen/Sparse>
#include <array>
#include <span>
#include <vector>

#include "player/sim/corotated_elasticity.h"

namespace fissure::sim {

class BlockSystem {
 public:
  /// The pattern of `tets` over the nodes whose `pinned` flag is 0.
  void build(const Matrix4Xu& tets, std::span<const std::uint8_t> pinned);

  [[nodiscard]] Index free_count() const { return static_cast<Index>(m_free_nodes.size()); }
  [[nodiscard]] Eigen::Index rows() const { return 3 * static_cast<Eigen::Index>(m_free_nodes.size()); }
  /// The free node of block row c.
  [[nodiscard]] NodeIndex free_node(Index c) const { return m_free_nodes[c]; }
  /// First of a node's three rows; kInvalidIndex for a pinned node.
  [[nodiscard]] Index row(NodeIndex node) const { return m_dof[node]; }
  /// Σ over the (tet, corner) slots of free node c, in tet order, of per_tet[tet].col(corner).
  [[nodiscard]] Vec3 gather(Index c, const std::vector<Mat34>& per_tet) const {
    Vec3 sum = Vec3::Zero();
    for (Index k = m_incidence_start[c]; k < m_incidence_start[c + 1]; ++k) {
      const auto& [t, corner] = m_incidence[k];
      sum += per_tet[t].col(corner);
    }
    return sum;
  }
  /// Calls f(tet, corner) for each slot of free node c, in tet order.
  template <typename F>
  void for_each_slot(Index c, F&& f) const {
    for (Index k = m_incidence_start[c]; k < m_incidence_start[c + 1]; ++k) f(m_incidence[k].first, m_incidence[k].second);
  }

  /// A's values from an evaluation, into the fixed pattern (both triangles).
  void assemble(const CorotatedElasticity& elasticity, const ElementBuffers& elements, const Eigen::VectorXd& mass,
                double k_scale, double m_scale);
  [[nodiscard]] const Eigen::SparseMatrix<double>& matrix() const { return m_matrix; }

  /// y = m_scale M x − k_scale K x, element by element (no matrix needed).
  void product(const CorotatedElasticity& elasticity, const ElementBuffers& elements, const Eigen::VectorXd& mass,
               double k_scale, double m_scale, const Eigen::VectorXd& x, Eigen::VectorXd& y);

  /// Block (i, j) of tet t's K from an evaluation (one term of A's blocks, before −k_scale).
  [[nodiscard]] static Mat3 tet_stiffness_block(TetIndex t, int i, int j, const CorotatedElasticity& elasticity,
                                                const ElementBuffers& elements) {
    return elements.model == StiffnessModel::Warped
               ? elasticity.warped_block(t, elements.rotated_gradients[t], i, j)
               : Mat3(elements.stiffness[t].block<3, 3>(3 * i, 3 * j));
  }

  /// A's 3×3 diagonal block of a free node.
  [[nodiscard]] Mat3 diagonal_block(NodeIndex node, const CorotatedElasticity& elasticity,
                                    const ElementBuffers& elements, double node_mass, double k_scale,
                                    double m_scale) const;

 private:
  /// One (tet, corner i, corner j) term of a 3×3 block.
  struct BlockTerm {
    TetIndex tet;
    std::uint8_t i, j;
  };
  /// Block `block` of −K from an evaluation, summed over its terms in tet order.
  [[nodiscard]] Mat3 stiffness_block(Index block, const CorotatedElasticity& elasticity,
                                     const ElementBuffers& elements) const;
  void build_blocks(const Matrix4Xu& tets);
  void build_matrix(const std::vector<Index>& block_rows);
  void build_incidence(const Matrix4Xu& tets);

  std::vector<Index> m_dof;                  ///< node → first row in the system, kInvalidIndex if pinned
  std::vector<NodeIndex> m_free_nodes;       ///< free node of each 3-row block, in row order
  std::vector<std::array<Index, 4>> m_tet_dofs;  ///< per tet: its corners' first rows, kInvalidIndex if pinned
  /// The system, both triangles, in whole 3×3 blocks: each block column (3 columns of
  /// one free node) lists the same rows. assemble() refills its values in place.
  Eigen::SparseMatrix<double> m_matrix;
  /// Per block (sorted by block column, then row): where its (0, 0) value is, whether it
  /// is a diagonal block, and its terms in tet order: a gather, so the blocks are filled
  /// in parallel and the sums do not depend on the thread count.
  std::vector<Index> m_block_value;
  std::vector<std::uint8_t> m_block_diagonal;
  std::vector<Index> m_block_column_start;   ///< per free node + 1: its first block
  std::vector<Index> m_block_term_start;     ///< per block + 1
  std::vector<BlockTerm> m_block_terms;
  /// Per free node + 1, and the (tet, corner) slots holding it, in tet order.
  std::vector<Index> m_incidence_start;
  std::vector<std::pair<TetIndex, int>> m_incidence;
  std::vector<Mat34> m_tet_product;          ///< per tet: K_t x_t (product's scratch)
};

}  // namespace fissure::sim
