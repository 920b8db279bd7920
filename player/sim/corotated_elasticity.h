#pragma once
/// Corotational linear elasticity on tetrahedra (thesis eqs. 4.1–4.8; docs/architecture.md,
/// "The physics in brief").
///
/// Per tet with rest nodes X0..X3 and current x0..x3: F = Σ xᵢ gᵢᵀ, where gᵢ are the
/// rest-shape gradients of the linear shape functions (g₀ = −g₁ − g₂ − g₃). F = Q S
/// (polar; Q a proper rotation even for inverted tets, from an SVD with the reflection
/// moved onto the smallest singular value). ε = sym(QᵀF) − I, σ = 2μ ε + λ tr(ε) I.
/// Energy Ψ = V (μ ‖ε‖² + λ/2 tr(ε)²); P = Q σ is its exact gradient w.r.t. F, and the
/// nodal forces are fᵢ = −V P gᵢ (so Σ fᵢ = 0: internal forces carry no net force).
///
/// Stiffness K = ∂f/∂x, per tet a symmetric 12×12 matrix, negative semi-definite, in
/// one of two models:
///  - Warped (thesis eq. 4.6): Q frozen. Cheap, but it ignores how the rotation turns
///    with the nodes, which under-estimates the stiffness against shear-rotation.
///  - Exact: the true Hessian of Ψ, including ∂Q/∂F, with its three "twist"
///    eigenvalues clamped at zero so it stays semi-definite (the other six
///    eigenvalues, 2μ and 2μ + 3λ, never go negative). Closed form after Kim & Eberle,
///    "Dynamic Deformables" (SIGGRAPH 2022 course), §5–7 (as-rigid-as-possible term
///    plus the trace term λ/2 (tr S − 3)²).

#include <vector>

#include "common/types.h"
#include "player/sim/lanes.h"
#include "player/sim/material.h"
#include "player/sim/polar_rotation.h"

namespace fissure::sim {

using Mat12 = Eigen::Matrix<double, 12, 12>;
using Mat34 = Eigen::Matrix<double, 3, 4>;

enum class StiffnessModel { Warped, Exact };

/// Per-tet results of one evaluation, written by tet index from any thread and read
/// back in tet order, so sums over them do not depend on the thread count.
struct ElementBuffers {
  StiffnessModel model = StiffnessModel::Warped;
  std::vector<Mat3> rotations;
  /// Q gᵢ per tet (columns): with the rest gradients they give the warped stiffness in
  /// closed form (CorotatedElasticity::warped_block), so no 12×12 matrix is stored.
  std::vector<Mat34> rotated_gradients;
  std::vector<Mat34> forces;      ///< column i: elastic force on the tet's node i [N]
  std::vector<Mat12> stiffness;   ///< exact model only: ∂f/∂x of the tet (node-major); empty when warped
  std::vector<Mat3> stress;       ///< world-frame stress Q σ Qᵀ [Pa]; filled only on request
};

class CorotatedElasticity {
 public:
  /// `rest` 3×#N [m], `tets` 4×#T positively oriented. Throws fissure::Error for a
  /// degenerate rest tet or an invalid material.
  CorotatedElasticity(const Matrix3Xd& rest, const Matrix4Xu& tets, const Material& material);

  /// New stiffness (E, ν) from the next evaluation on; throws fissure::Error for an invalid material.
  void set_material(const Material& material);

  [[nodiscard]] std::size_t tet_count() const { return m_volume.size(); }
  [[nodiscard]] double rest_volume(TetIndex t) const { return m_volume[t]; }
  [[nodiscard]] const Matrix4Xu& tets() const { return m_tets; }
  /// Rest gradients gᵢ of the tet's shape functions (columns).
  [[nodiscard]] const Mat34& shape_gradients(TetIndex t) const { return m_gradients[t]; }

  /// Points corner `corner` of tet `t` at another node with the same rest position
  /// (fracture); the tet's rest shape, and so its gradients, do not change.
  void replace_node(TetIndex t, int corner, NodeIndex node) {
    m_tets(corner, t) = node;
    m_last_energy.known = false;
  }

  /// Elastic energy [J] at positions x (3×#N). The last answer is kept with its
  /// positions and given again for the same positions, bit for bit: the energy guard
  /// measures each substep's start, which is the last substep's end.
  [[nodiscard]] double energy(const Matrix3Xd& x) const;
  /// Elastic energy [J] of tet t alone at positions x (3×#N).
  [[nodiscard]] double tet_energy(const Matrix3Xd& x, TetIndex t) const;

  /// Deformation gradients F of every tet at x, in parallel.
  void deformation_gradients(const Matrix3Xd& x, std::vector<Mat3>& out) const;

  /// Rotations Q of every tet at x.
  void rotations(const Matrix3Xd& x, std::vector<Mat3>& out) const;

  /// Adds the elastic forces [N] at x, with each tet's rotation `rotations[t]`
  /// (pass the polar rotations at x for the true forces), to `out` (3×#N).
  void add_forces(const Matrix3Xd& x, const std::vector<Mat3>& rotations, Matrix3Xd& out) const;

  /// K_t = ∂f_t/∂x_t with Q_t frozen, rows/columns ordered node-major (node 0 x,y,z, …).
  [[nodiscard]] Mat12 stiffness(TetIndex t, const Mat3& rotation) const;

  /// Block (i, j) of the warped K_t from the rotated gradients ĝ = Q g:
  ///   K_ij = −V (μ (gᵢ·gⱼ) I + μ ĝⱼ ĝᵢᵀ + λ ĝᵢ ĝⱼᵀ).
  /// About 40 flops, against 144 stored values for the whole 12×12 matrix.
  [[nodiscard]] Mat3 warped_block(TetIndex t, const Mat34& rotated_gradients, int i, int j) const {
    const Mat34& g = m_gradients[t];
    const double v = m_volume[t];
    Mat3 block = (-v * m_mu) * rotated_gradients.col(j) * rotated_gradients.col(i).transpose() -
                 (v * m_lambda) * rotated_gradients.col(i) * rotated_gradients.col(j).transpose();
    block.diagonal().array() -= v * m_mu * g.col(i).dot(g.col(j));
    return block;
  }

  /// K_t u_t for the tet's four node vectors u (columns), from the last evaluation's
  /// buffers, in either stiffness model. Warped: with W = Σⱼ uⱼ ĝⱼᵀ,
  /// (K u)ᵢ = −V (μ (W + Wᵀ) + λ tr(W) I) ĝᵢ.
  [[nodiscard]] Mat34 stiffness_times(TetIndex t, const ElementBuffers& buffers, const Mat34& u) const;
  /// out[l] = K u[l] of tet first + l, for count ≤ kLanes consecutive tets: the
  /// same products, the warped model's a batch per SIMD register (they are the
  /// conjugate-gradient product's whole per-tet work).
  void stiffness_times(TetIndex first, int count, const ElementBuffers& buffers, const Mat34* u, Mat34* out) const;

  /// The exact K_t = ∂f_t/∂x_t at x (rotation differentiated). With `project` its
  /// indefinite part is clamped so that −K_t is positive semi-definite.
  [[nodiscard]] Mat12 exact_stiffness(TetIndex t, const Matrix3Xd& x, bool project = true) const;

  /// Rotations, forces and stiffness of every tet at x, in parallel (TBB); the world
  /// stress too when `with_stress` (fracture needs it).
  void evaluate(const Matrix3Xd& x, StiffnessModel model, bool with_stress, ElementBuffers& out) const;

 private:
  Matrix4Xu m_tets;
  std::vector<Mat34> m_gradients;  ///< gᵢ per tet (columns)
  std::vector<double> m_volume;
  double m_mu, m_lambda;
  /// energy()'s last answer and the positions it is for (a polar decomposition per tet
  /// saved when asked again; EnergyGuard::measure_substep_start), with each tet's F and Q
  /// there. The energy guard measures a substep's end, and the next substep's
  /// evaluate() starts from the same positions: it takes F and Q from here, the same
  /// bits it would compute (the same sums and the same lane batches).
  struct LastEnergy {
    Matrix3Xd positions;
    double value = 0;
    bool known = false;
    std::vector<Mat3> F, Q;
  };
  mutable LastEnergy m_last_energy;

  [[nodiscard]] Mat3 deformation_gradient(const Matrix3Xd& x, TetIndex t) const;
  /// energy() without the last answer; keeps each tet's F and Q in m_last_energy.
  [[nodiscard]] double summed_energy(const Matrix3Xd& x) const;
  /// Whether m_last_energy holds F and Q at exactly these positions.
  [[nodiscard]] bool knows_gradients_at(const Matrix3Xd& x) const;
  /// Tet first + l's rest gradients, volume and (with `positions`) node positions in lane
  /// l, for l < kLanes; a short batch (size < kLanes) repeats its first tet.
  void gather_lanes(const Matrix3Xd& x, std::size_t first, int size, bool positions, double (&x_lanes)[12][kLanes],
                    double (&g_lanes)[12][kLanes], double (&volume)[kLanes]) const;
  [[nodiscard]] Mat12 exact_stiffness(TetIndex t, const Mat3& F, const SignedSvd& svd, bool project) const;
  [[nodiscard]] Mat3 stress(const Mat3& rotation, const Mat3& F) const;
  /// Tet t's energy at deformation gradient F, with Q its polar rotation.
  [[nodiscard]] double energy_at(TetIndex t, const Mat3& F, const Mat3& Q) const {
    const Mat3 S = Q.transpose() * F;
    const Mat3 strain = 0.5 * (S + S.transpose()) - Mat3::Identity();
    const double trace = strain.trace();
    return m_volume[t] * (m_mu * strain.squaredNorm() + 0.5 * m_lambda * trace * trace);
  }
};

}  // namespace fissure::sim
