#pragma once
/// Corotational linear elasticity on tetrahedra (thesis eqs. 4.1–4.8, DESIGN.md).
///
/// Per tet with rest nodes X0..X3 and current x0..x3: F = Σ xᵢ gᵢᵀ, where gᵢ are the
/// rest-shape gradients of the linear shape functions (g₀ = −g₁ − g₂ − g₃). F = Q S
/// (polar; Q a proper rotation even for inverted tets, from an SVD with the reflection
/// moved onto the smallest singular value). ε = sym(QᵀF) − I, σ = 2μ ε + λ tr(ε) I.
/// Energy Ψ = V (μ ‖ε‖² + λ/2 tr(ε)²); P = Q σ is its exact gradient w.r.t. F, and the
/// nodal forces are fᵢ = −V P gᵢ (so Σ fᵢ = 0: internal forces carry no net force).
///
/// Stiffness: K = ∂f/∂x with Q frozen (the "warped" linearization of eq. 4.6): per tet
/// a symmetric 12×12 matrix, negative semi-definite.

#include <vector>

#include "common/types.h"
#include "player/sim/material.h"

namespace fissure::sim {

using Mat12 = Eigen::Matrix<double, 12, 12>;

/// The rotation of F's polar decomposition, proper (det = +1) even when F is inverted
/// or degenerate.
Mat3 polar_rotation(const Mat3& F);

class CorotatedElasticity {
 public:
  /// `rest` 3×#N [m], `tets` 4×#T positively oriented. Throws fissure::Error for a
  /// degenerate rest tet or an invalid material.
  CorotatedElasticity(const Matrix3Xd& rest, const Matrix4Xu& tets, const Material& material);

  [[nodiscard]] std::size_t tet_count() const { return m_volume.size(); }
  [[nodiscard]] double rest_volume(TetIndex t) const { return m_volume[t]; }
  [[nodiscard]] const Matrix4Xu& tets() const { return m_tets; }

  /// Elastic energy [J] at positions x (3×#N).
  [[nodiscard]] double energy(const Matrix3Xd& x) const;

  /// Rotations Q of every tet at x.
  void rotations(const Matrix3Xd& x, std::vector<Mat3>& out) const;

  /// Adds the elastic forces [N] at x, with each tet's rotation `rotations[t]`
  /// (pass the polar rotations at x for the true forces), to `out` (3×#N).
  void add_forces(const Matrix3Xd& x, const std::vector<Mat3>& rotations, Matrix3Xd& out) const;

  /// K_t = ∂f_t/∂x_t with Q_t frozen, rows/columns ordered node-major (node 0 x,y,z, …).
  [[nodiscard]] Mat12 stiffness(TetIndex t, const Mat3& rotation) const;

 private:
  Matrix4Xu m_tets;
  Matrix3Xd m_rest;
  std::vector<Eigen::Matrix<double, 3, 4>> m_gradients;  ///< gᵢ per tet (columns)
  std::vector<double> m_volume;
  double m_mu, m_lambda;

  [[nodiscard]] Mat3 deformation_gradient(const Matrix3Xd& x, TetIndex t) const;
};

}  // namespace fissure::sim
