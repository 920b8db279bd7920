#pragma once
/// A body's loosely held nodes, eliminated exactly from the lagged preconditioner's
/// system each step (record 0084).
///
/// A lagged factor (LaggedCholesky) is made once and then only follows each node's
/// rotation. Fracture leaves tets that hang by an edge or a node (a hinge: the tets share
/// it but no face, as thesis IV.G's node splitting keeps them attached). Such a tet is
/// tiny against its stiffness (h²K/m of 10³–10⁵ on the bunny cages) and swings about
/// its hinge far faster than the body turns, up to tens of radians a step. The hinge
/// node's rotation follows the body, so the factor's picture of the tet's stiffness is
/// rotated wrongly there: the step's conjugate gradients spent 15–35 iterations on a few
/// such nodes and the 10,024-tet cage refactored every other step.
///
/// A loose node is one in at most `max_slots` tets; loose nodes joined through a tet
/// form a part. With A split into the loose rows l and the rest (the core c),
/// A = [[A_ll, A_lc], [A_cl, A_cc]] has the exact block inverse through the Schur
/// complement S = A_cc − A_cl A_ll⁻¹ A_lc. The preconditioner takes A_ll and A_lc afresh
/// from each step's evaluation, and for S⁻¹ the core rows of the lagged factor's solve
/// with the loose rows of its right-hand side zeroed: that is the inverse of the
/// factor's own Schur complement on the core, so the whole stays symmetric positive
/// definite whatever the factor makes of the loose rows, and is close to S where the
/// loose tets only hang (their share of S is then little more than their mass).

#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "common/types.h"
#include "player/sim/block_system.h"
#include "player/sim/corotated_elasticity.h"

namespace fissure::sim {

class LooseNodes {
 public:
  /// Finds the loose nodes (none if max_slots is 0), in parts joined through tets; a
  /// part of more than `max_part_nodes` nodes, too large to factor densely each step,
  /// stays in the core. After every change of A's pattern.
  void find(const Matrix4Xu& tets, const BlockSystem& system, int max_slots, int max_part_nodes);
  [[nodiscard]] std::size_t loose_count() const { return m_loose_count; }
  [[nodiscard]] bool loose(Index block) const { return m_place[block] != kInvalidIndex; }
  [[nodiscard]] bool empty() const { return m_parts.empty(); }

  /// Each part's A_ll (factored) and A_lc from this evaluation of A = m_scale M − k_scale K.
  void update(const CorotatedElasticity& elasticity, const ElementBuffers& elements, const Eigen::VectorXd& mass,
              const BlockSystem& system, double k_scale, double m_scale);

  /// z = the block inverse above applied to r, with `core(r', z')` the lagged solve.
  template <typename Core>
  void precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z, Core&& core) {
    eliminate(r);
    core(m_core_residual, z);
    back_substitute(z);
  }

 private:
  /// A_lc's block between loose node `place` of its part and core row block `core`.
  struct Coupling {
    Index place;
    Index core;
    Mat3 block;
  };
  struct Part {
    std::vector<Index> blocks;             ///< its loose nodes' 3-row blocks
    std::vector<TetIndex> tets;            ///< the tets holding any of them
    Eigen::LLT<Eigen::MatrixXd> loose;     ///< A_ll
    bool factored = false;                 ///< A_ll's factorization succeeded this step
    std::vector<Coupling> couplings;       ///< A_lc
    Eigen::VectorXd answer;                ///< y_l = A_ll⁻¹ r_l (scratch of precondition())
    Eigen::VectorXd pull;                  ///< A_ll⁻¹ A_lc z_c (scratch of precondition())
  };
  void update_part(Part& part, const CorotatedElasticity& elasticity, const ElementBuffers& elements,
                   const Eigen::VectorXd& mass, const BlockSystem& system, double k_scale, double m_scale) const;
  /// y_l per part, and r' = r_c − A_cl y_l with the loose rows zeroed.
  void eliminate(const Eigen::VectorXd& r);
  /// z_l = y_l − A_ll⁻¹ A_lc z_c.
  void back_substitute(Eigen::VectorXd& z);

  std::vector<Part> m_parts;
  std::vector<Index> m_place;  ///< per free block: its place in its part, kInvalidIndex if not loose
  std::size_t m_loose_count = 0;
  Eigen::VectorXd m_core_residual;
};

}  // namespace fissure::sim
