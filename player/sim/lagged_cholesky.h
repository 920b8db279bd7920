#pragma once
/// The sparse Cholesky factor of the implicit system, kept across steps (see
/// Preconditioner::LaggedCholesky): the direct solver refactors it every step; conjugate
/// gradients keep it as a preconditioner P = R A_f Rᵀ until it goes stale, R being each
/// free node's rotation since the factorization (the polar part of the sum of its tets'
/// rotation changes), so P follows large rigid-like motion without refactoring.

#include <Eigen/Sparse>
#include <vector>

#include "player/sim/block_system.h"
#include "player/sim/sparse_cholesky.h"

namespace fissure::sim {

class LaggedCholesky {
 public:
  /// Forgets the factor and its analysis (the pattern changed).
  void reset() { m_cholesky.reset(); }
  [[nodiscard]] bool factorized() const { return m_cholesky.factorized(); }
  /// Whether a preconditioner made at these scales must be remade: never made, the last
  /// solve took more than `refactor_iterations`, or dt (so the scales) changed.
  [[nodiscard]] bool stale(int last_iterations, int refactor_iterations, double k_scale, double m_scale) const {
    return !factorized() || last_iterations > refactor_iterations || k_scale != m_k_scale || m_scale != m_m_scale;
  }

  /// Factors A = m_scale M − k_scale K, made with the tets' `rotations`. A large factor
  /// is kept in float when `allow_single` (a preconditioner's), see the .cpp. False when
  /// A is not positive definite.
  [[nodiscard]] bool factorize(const Eigen::SparseMatrix<double>& A, double k_scale, double m_scale,
                               const std::vector<Mat3>& rotations, bool allow_single);
  /// x = A⁻¹ b with the factor as made.
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const { m_cholesky.solve(b, x); }

  /// Each free node's rotation since the factorization, from the tets' current ones.
  void follow_rotations(const std::vector<Mat3>& rotations, const BlockSystem& system);
  /// z = R A_f⁻¹ Rᵀ r with the rotations of the last follow_rotations().
  void rotated_solve(const Eigen::VectorXd& r, Eigen::VectorXd& z) const;

 private:
  SparseCholesky m_cholesky;
  double m_k_scale = 0.0, m_m_scale = 0.0;     ///< the scales the factor was made with
  std::vector<Mat3> m_factored_rotations;      ///< per tet: its rotation when A_f was factored
  std::vector<Mat3> m_node_rotation;           ///< per free node: its rotation since then
  std::vector<Mat3> m_tet_rotation_change;     ///< per tet: Q_t Q_t,fᵀ (scratch)
};

}  // namespace fissure::sim
