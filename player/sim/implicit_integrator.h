#pragma once
/// Implicit backward Euler for one deformable body (Baraff & Witkin 1998; DESIGN.md):
///   (M − h D − h² K) Δv = h (f + h K v),  v ← v + Δv,  x ← x + h v
/// with K = ∂f/∂x (corotated, Q frozen at the start of the step), Rayleigh damping
/// D = −α M + β K, lumped masses, gravity, and pinned nodes removed from the system.
/// The sparsity pattern is built once; each step only refills its values, and the
/// direct solver reuses its symbolic analysis.

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <array>
#include <vector>

#include "player/sim/corotated_elasticity.h"

namespace fissure::sim {

enum class LinearSolver { Direct, ConjugateGradient };

enum class SolveStatus { Converged, MaxIterations, NotPositiveDefinite, NonFinite };

struct StepSettings {
  double dt = 1.0 / 240.0;             ///< [s]
  Vec3 gravity = Vec3(0.0, 0.0, -9.81);  ///< [m/s²]
  LinearSolver solver = LinearSolver::Direct;
  double tolerance = 1e-8;             ///< relative residual for conjugate gradients
  int max_iterations = 1000;           ///< conjugate-gradient cap
};

class ImplicitIntegrator {
 public:
  /// `rest` 3×#N, `tets` 4×#T; masses lumped from density × tet volume / 4.
  ImplicitIntegrator(const Matrix3Xd& rest, const Matrix4Xu& tets, const Material& material);

  Matrix3Xd positions;   ///< 3×#N current [m]
  Matrix3Xd velocities;  ///< 3×#N current [m/s]

  void pin(NodeIndex node);  ///< fixes a node where it is (re-analyses the pattern)
  [[nodiscard]] const Eigen::VectorXd& node_masses() const { return m_mass; }
  [[nodiscard]] const CorotatedElasticity& elasticity() const { return m_elasticity; }

  /// Advances one step; returns how the linear solve went. On anything but Converged
  /// the state is left unchanged, so the caller can retry with a smaller dt.
  SolveStatus step(const StepSettings& settings);

  [[nodiscard]] int last_iterations() const { return m_iterations; }

  /// Wall-clock seconds of the last step's phases.
  struct PhaseTimes {
    double forces = 0;    ///< rotations and elastic, gravity and damping forces
    double assembly = 0;  ///< element stiffness and the system's values
    double solve = 0;     ///< factorization and solve, or CG
  };
  [[nodiscard]] const PhaseTimes& last_phase_times() const { return m_phase_times; }

  /// Total kinetic + elastic energy [J] (no gravity).
  [[nodiscard]] double energy() const;

 private:
  void build_pattern();

  CorotatedElasticity m_elasticity;
  Material m_material;
  Eigen::VectorXd m_mass;           ///< #N lumped masses [kg]
  std::vector<std::uint8_t> m_pinned;
  std::vector<Index> m_dof;         ///< node → first row in the system, kInvalidIndex if pinned
  Eigen::SparseMatrix<double> m_matrix;
  /// Per tet, per (i, j) node pair and block column c: where that column's 3 rows start
  /// in the compressed storage (null when a node is pinned). Steps write through these.
  std::vector<std::array<double*, 48>> m_blocks;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> m_direct;
  Eigen::VectorXd m_last_dv;        ///< warm start for conjugate gradients
  bool m_analyzed = false;
  int m_iterations = 0;
  PhaseTimes m_phase_times;
};

}  // namespace fissure::sim
