#pragma once
/// Implicit backward Euler for one deformable body (Baraff & Witkin 1998; docs/architecture.md,
/// "The physics in brief"):
///   (M − h D − h² K) Δv = h (f + h K v),  v ← v + Δv,  x ← x + h v
/// with K = ∂f/∂x at the start of the step (warped or exact, see CorotatedElasticity),
/// Rayleigh damping D = −α M + β K, lumped masses, gravity, and pinned nodes removed
/// from the system. The sparsity pattern is built once and rebuilt only when fracture
/// splits a node; steps refill its values in place, and the direct solver reuses its
/// symbolic analysis until the pattern changes. Conjugate gradients with the lagged
/// Cholesky preconditioner never need the matrix itself (they multiply element by
/// element), so it is assembled only on the steps that refresh the factor.
///
/// A step is two calls so fracture can act in between: evaluate() computes every
/// tet's rotation, forces and stiffness (in parallel); solve() assembles and solves.
/// Splitting a node copies its position and velocity, so the evaluated tet data stays
/// valid across splits.

#include <Eigen/Sparse>
#include <array>
#include <memory>
#include <span>
#include <vector>

#include "player/sim/corotated_elasticity.h"
#include "player/sim/block_system.h"
#include "player/sim/lagged_cholesky.h"
#include "player/sim/loose_nodes.h"

namespace fissure::sim {

enum class LinearSolver { Direct, ConjugateGradient };

/// What conjugate gradients are preconditioned with.
///  - Jacobi: the diagonal. Cheap per iteration, but the iteration count grows with
///    h²E/(ρL²): hundreds on a fine cage.
///  - LaggedCholesky: the exact Cholesky factor of an earlier step's matrix A_f. Between
///    steps the (warped) matrix changes only through the tet rotations, and a rotation
///    that is shared by a neighbourhood conjugates its blocks: A ≈ R A_f Rᵀ with R
///    block-diagonal, each node's rotation since the factorization (the polar part of
///    the sum of its tets' rotation changes). So P = R A_f Rᵀ stays a close
///    preconditioner through large rigid-like motion, and is refactored only when an
///    iteration count exceeds `refactor_iterations` (at once, within a solve that runs
///    to 4× that), the pattern changes (fracture) or dt changes.
enum class Preconditioner { Jacobi, LaggedCholesky };

enum class SolveStatus { Converged, MaxIterations, NotPositiveDefinite, NonFinite };

[[nodiscard]] const char* to_string(SolveStatus status);

struct StepSettings {
  double dt = 1.0 / 240.0;             ///< [s]
  Vec3 gravity = Vec3(0.0, 0.0, -9.81);  ///< [m/s²]
  LinearSolver solver = LinearSolver::Direct;
  StiffnessModel stiffness = StiffnessModel::Warped;
  double tolerance = 1e-8;             ///< relative residual for conjugate gradients
  int max_iterations = 1000;           ///< conjugate-gradient cap
  Preconditioner preconditioner = Preconditioner::LaggedCholesky;
  /// LaggedCholesky: refactor after a solve that took more iterations, and within a solve
  /// once it has taken 4× as many (record 0085).
  int refactor_iterations = 8;
  /// LaggedCholesky: nodes in at most this many tets are eliminated afresh each step
  /// beside the factor (LooseNodes); 0 = none. 3 takes the 10,024-tet bunny cage's step
  /// ×0.67 but the 987-tet sample's variants ×1.05 (record 0084).
  int loose_node_slots = 0;
};

/// How tet mass is spread to nodes (thesis III.D.2). Without it, each node gets a
/// quarter of density × volume of each incident tet.
struct MassDistribution {
  /// #T fraction of each tet's volume that is solid (the bake's mass_fraction).
  std::vector<double> fraction;
  /// #T barycentric centre of mass of the solid part; the tet's mass goes to its
  /// nodes in these proportions, so the body's mass and centre of mass are the solid's.
  std::vector<Vec4> center_of_mass;
};

class ImplicitIntegrator {
 public:
  /// `rest` 3×#N, `tets` 4×#T. Throws fissure::Error for invalid input.
  ImplicitIntegrator(const Matrix3Xd& rest, const Matrix4Xu& tets, const Material& material,
                     const MassDistribution* mass = nullptr);
  // The system matrix holds pointers into its own storage: not copyable or movable.
  ImplicitIntegrator(const ImplicitIntegrator&) = delete;
  ImplicitIntegrator& operator=(const ImplicitIntegrator&) = delete;

  [[nodiscard]] const Matrix3Xd& positions() const { return m_positions; }    ///< 3×#N current [m]
  [[nodiscard]] const Matrix3Xd& velocities() const { return m_velocities; }  ///< 3×#N current [m/s]
  /// Replace the state (a scene's initial velocities, a test's deformed start). The
  /// next conjugate-gradient solve does not extrapolate across the jump. Throws
  /// fissure::Error when the size is not 3×#N or a value is not finite.
  void set_positions(const Matrix3Xd& x);
  void set_velocities(const Matrix3Xd& v);

  /// A new material from the next step on (a viewer's live sliders): stiffness, density
  /// (node masses scale with it; the momentum they carry is not kept) and damping. The
  /// next solve refactors. Throws fissure::Error for an invalid material.
  void set_material(const Material& material);

  [[nodiscard]] Index node_count() const { return static_cast<Index>(m_positions.cols()); }
  [[nodiscard]] const Matrix3Xd& rest_positions() const { return m_rest; }
  [[nodiscard]] const Eigen::VectorXd& node_masses() const { return m_mass; }
  [[nodiscard]] double tet_mass(TetIndex t) const { return m_tet_mass[t]; }
  [[nodiscard]] const CorotatedElasticity& elasticity() const { return m_elasticity; }
  [[nodiscard]] const Material& material() const { return m_material; }
  [[nodiscard]] bool pinned(NodeIndex node) const { return m_pinned[node] != 0; }
  [[nodiscard]] std::span<const std::uint8_t> pinned_nodes() const { return m_pinned; }  ///< #N, nonzero: pinned
  /// 1 / mass, 0 for a pinned node (what contacts may move).
  [[nodiscard]] double inverse_mass(NodeIndex node) const { return m_pinned[node] ? 0.0 : 1.0 / m_mass[node]; }

  /// Fixes nodes where they are; the pattern is rebuilt once, on the next solve.
  void pin(std::span<const NodeIndex> nodes);
  void pin(NodeIndex node) { pin(std::span<const NodeIndex>(&node, 1)); }

  /// Holds nodes still where they are, as if pinned, until released (a fragment asleep,
  /// World): pinned nodes stay pinned. The pattern is rebuilt once, on the next solve.
  void hold(std::span<const NodeIndex> nodes);
  /// Frees held nodes, at rest; pinned ones stay pinned.
  void release(std::span<const NodeIndex> nodes);
  [[nodiscard]] bool held(NodeIndex node) const { return m_pinned[node] == kHeld; }

  /// Splits `node`: a new node with the same rest and current position and velocity
  /// takes the given (tet, corner) slots, which must currently hold `node`. Masses are
  /// re-lumped, so momentum is unchanged. Returns the new node's index.
  NodeIndex split_node(NodeIndex node, std::span<const std::pair<TetIndex, int>> slots);

  /// Undoes the last split_node (which returned `added`): its slots go back to `node`,
  /// the node is removed and masses re-lumped, exactly as before the split. Splits must
  /// be undone newest first.
  void undo_split(NodeIndex node, NodeIndex added);

  /// Everything a step changes but the topology (see undo_split): taken before a step,
  /// put back when it fails, so the body is exactly as it was, warm start included.
  /// The lagged factor is a cache and is not saved: a failed step that refreshed it, or
  /// split a node, leaves a fresh factor to be made on the next solve.
  struct Checkpoint {
    Matrix3Xd positions, velocities, last_dv, previous_dv;
    int smooth_solves = 0, iterations = 0;
    double last_dt = 0;
  };
  void save(Checkpoint& out) const;
  /// Restores a checkpoint taken with the current node count (undo splits first).
  void restore(const Checkpoint& checkpoint);

  /// Does at load what the first solve() with these settings would: builds the system's
  /// pattern and, for conjugate gradients with the lagged Cholesky factor, factors the
  /// system at the current positions. The first step then answers exactly as without it
  /// and no longer pays the analysis and factorization (issue 42: a 92,747-tet beam's
  /// first step took 5.1 s; a game loads, then must not hitch). False when the factor
  /// failed (the first solve() will report it).
  bool prepare(const StepSettings& settings);

  /// Advances one step: evaluate() then solve(). On anything but Converged or
  /// MaxIterations the state is left unchanged, so the caller can retry with a smaller dt.
  SolveStatus step(const StepSettings& settings);

  /// Rotations, forces and stiffness of every tet at the current positions.
  void evaluate(const StepSettings& settings, bool with_stress);
  [[nodiscard]] const ElementBuffers& elements() const { return m_elements; }
  /// Assembles from the last evaluate() and solves. MaxIterations still advances the
  /// state with the best iterate (real-time use); NotPositiveDefinite and NonFinite
  /// leave it unchanged.
  SolveStatus solve(const StepSettings& settings);

  /// The last solve's system A, for a contact response that stays inside the implicit
  /// step (contact_response.h): a velocity correction δ answering impulses f must solve
  /// A δ = f, so the body responds to a contact as a whole, elastically, within the step.
  /// Valid from a solve() until the next evaluate(), split or pin.
  [[nodiscard]] Eigen::Index system_size() const { return m_system.rows(); }
  /// First of a free node's three rows in the system; kInvalidIndex for a pinned node.
  [[nodiscard]] Index system_row(NodeIndex node) const { return m_system.row(node); }
  /// A's mass term is this times M (1 + h α with Rayleigh mass damping).
  [[nodiscard]] double system_mass_scale() const { return m_system_m_scale; }
  [[nodiscard]] bool has_pinned_nodes() const { return m_system.free_count() != m_pinned.size(); }
  /// A's 3×3 diagonal block of a free node.
  [[nodiscard]] Mat3 system_diagonal_block(NodeIndex node) const;
  /// Tet t's term in A's block (i, j) of its corners: −k_scale K_t(i, j). A's block of
  /// two free nodes is the sum of these over the tets holding both, plus the mass term
  /// on the diagonal.
  [[nodiscard]] Mat3 system_tet_block(TetIndex t, int i, int j) const;
  /// y = A x.
  void multiply_system(const Eigen::VectorXd& x, Eigen::VectorXd& y);
  /// z ≈ A⁻¹ r with the last solve's preconditioner (the exact factor for the direct solver).
  void precondition_system(const Eigen::VectorXd& r, Eigen::VectorXd& z);
  /// v += δ and x += h δ on the free nodes (δ indexed by system rows); the next solve
  /// starts from the corrected Δv.
  void correct_velocities(const Eigen::VectorXd& delta, double h);
  /// The motion a contact response changes (positions, velocities, the Δv the next solve
  /// starts from), to try two responses within one step and keep a blend of them
  /// (World::collide). Restoring keeps the last solve's system valid, unlike restore().
  struct Motion {
    Matrix3Xd positions, velocities, last_dv;
  };
  void save_motion(Motion& out) const;
  void restore_motion(const Motion& motion);
  /// Moves each fragment's rigid rotation since `start` (the positions before the step)
  /// on an arc instead of a line (rigid_rotation.h); `node_fragment[n]` is in
  /// [0, fragments). Returns the largest angle turned [rad].
  double rotate_rigid_parts(const Matrix3Xd& start, std::span<const Index> node_fragment, Index fragments,
                            std::span<const std::uint8_t> rigid_fragments = {});
  /// Moves only the fragments with `chosen[f]` nonzero rigidly since `start`: their
  /// start's shape moved and turned, their velocities the rigid field carrying their
  /// momenta (rigid_rotation.h); every other node stays as it is.
  void move_rigidly(const Matrix3Xd& start, std::span<const Index> node_fragment, Index fragments,
                    std::span<const std::uint8_t> chosen);

  /// What solve_exactly() did.
  struct ExactSolve {
    int iterations = 0;      ///< Newton iterations
    int factorizations = 0;  ///< of A: the first iteration's, and where an old one no longer served
    bool converged = false;  ///< the Newton decrement fell below the tolerance
    /// Newton started from the start's own velocities (x₀ + h v₀), where E was lower than
    /// at solve()'s answer.
    bool from_inertial_guess = false;
    /// NotPositiveDefinite: a factorization failed; the body is back at solve()'s answer,
    /// solved again, so the contact response has a valid system.
    SolveStatus status = SolveStatus::Converged;
  };
  /// Backward Euler solved to convergence (Gast et al. 2015, "Optimization integrator for
  /// large time steps"): Newton iterations on the step's incremental potential
  ///   E(v) = ½ (v − v₀)ᵀ M (v − v₀) + Ψ(x₀ + h v) − h gᵀ M v + ½ h α vᵀ M v − ½ h β vᵀ K₀ v,
  /// whose stationary point is the step's equation with the elastic forces at the end of
  /// the step (K₀: the stiffness at its start, as solve() damps with). solve() takes one
  /// linear step with the forces linearised about the start; a part turning fast about a
  /// hinge, or a stiff body crushed, then ends the step on lines with strain the linear
  /// model did not see, and energy the step did not have (issue 16). Here each iteration
  /// takes a Newton step on ∇²E, with the exact stiffness (projected, so A stays positive
  /// definite), by conjugate gradients preconditioned by a factor of A: the first
  /// iteration's, refreshed where the gradients take long (refine_toward_hessian); a
  /// backtracking line search keeps E from rising. Call after solve(), before another
  /// evaluate(); `start`: the state solve() started from, saved with save(). Starts from
  /// the current positions x, at v = (x − x₀) / h: solve()'s answer, or that answer turned
  /// on arcs (World does: it starts with less strain). Leaves the last iteration's system
  /// for the contact response. `impulses` (system rows, or null): impulses held fixed
  /// through the step, −vᵀ p added to E, so the body answers them nonlinearly (World
  /// passes the contact response's, A δ).
  ExactSolve solve_exactly(const StepSettings& settings, const Checkpoint& start, int max_iterations,
                           const Eigen::VectorXd* impulses = nullptr);

  [[nodiscard]] int last_iterations() const { return m_iterations; }
  /// Numeric Cholesky factorizations so far (direct solves, and LaggedCholesky refreshes).
  [[nodiscard]] int factorizations() const { return m_factorizations; }

  /// Wall-clock seconds of the last step's phases.
  struct PhaseTimes {
    double forces = 0;    ///< rotations, elastic forces and element stiffness (evaluate)
    double assembly = 0;  ///< the right-hand side, and the matrix when a factorization or Jacobi needs it
    double solve = 0;     ///< factorization and solve, or CG (with any refactorization)
  };
  [[nodiscard]] const PhaseTimes& last_phase_times() const { return m_phase_times; }

  /// Total kinetic + elastic energy [J] (no gravity).
  [[nodiscard]] double energy() const;
  [[nodiscard]] double kinetic_energy() const;
  [[nodiscard]] Vec3 linear_momentum() const { return m_velocities * m_mass; }
  [[nodiscard]] Vec3 angular_momentum() const;  ///< about the origin

 private:
  /// solve_exactly()'s pieces, at the velocities of the free nodes `v` (system order):
  /// puts the nodes at x₀ + h v; E(v); −∇E(v) from the last evaluate() at those positions.
  void place(const Checkpoint& start, const Eigen::VectorXd& v, double h);
  [[nodiscard]] double incremental_potential(const StepSettings& s, const Checkpoint& start, const Eigen::VectorXd& v,
                                             const Eigen::VectorXd* impulses);
  [[nodiscard]] Eigen::VectorXd incremental_residual(const StepSettings& s, const Checkpoint& start,
                                                     const Eigen::VectorXd& v, const Eigen::VectorXd* impulses);
  /// y = ∇²E x, the Hessian of solve_exactly()'s E at the last evaluate(): its damping
  /// term is −h β K₀ (the stiffness at the step's start, m_start_elements), where the
  /// assembled A has −h β K(x), so ∇²E x = A x + h β (K(x) − K₀) x; `damping` is h β.
  void multiply_hessian(double damping, const Eigen::VectorXd& x, Eigen::VectorXd& y);
  /// From dv = P⁻¹ b (P the factored A: this iteration's where `fresh`, else an earlier
  /// one's) toward ∇²E⁻¹ b (solve_exactly()): conjugate gradients on ∇²E from dv,
  /// preconditioned by P; `damping` is h β. Nothing to do where P is ∇²E (fresh, β = 0).
  struct HessianStep {
    int iterations = 0;
    bool converged = false;
  };
  HessianStep refine_toward_hessian(double damping, bool fresh, const Eigen::VectorXd& b, Eigen::VectorXd& dv);
  /// Armijo backtracking from v along dv (decrement −∇Eᵀdv): v, energy and the nodes move
  /// to the first step that lowers E enough. False, and the nodes back at v, when none does.
  /// The system's scales of K and M for a step of h (A = m_scale M − k_scale K).
  void set_system_scales(double h);
  bool backtrack(const StepSettings& s, const Checkpoint& start, const Eigen::VectorXd* impulses,
                 const Eigen::VectorXd& dv, double decrement, Eigen::VectorXd& v, double& energy);
  /// Per tet K₀ v at its corners, into m_tet_rhs (β damping's term; zero without β).
  void start_stiffness_times(const Eigen::VectorXd& v);
  /// b of A Δv = b, from the last evaluate().
  Eigen::VectorXd right_hand_side(const StepSettings& settings);
  /// Factors the assembled system (counted); `lagged`: as a preconditioner.
  bool refactor(bool lagged);
  /// A's pattern after a split or pin (forgets the factor), and the loose nodes after
  /// either or a new StepSettings::loose_node_slots.
  void update_pattern(const StepSettings& settings);
  /// Conjugate gradients from the warm start; Δv into dv. With `may_refactor` (a lagged
  /// factor made before this solve), a solve that runs long refactors and goes on.
  SolveStatus solve_iteratively(const StepSettings& settings, const Eigen::VectorXd& b, Eigen::VectorXd& dv,
                                bool may_refactor);
  /// v += Δv, x += h v on the free nodes; remembers Δv for the next warm start.
  void advance(const Eigen::VectorXd& dv, double h);
  void compute_tet_masses(double density);  ///< then lumps them
  void lump_masses();
  void check_state(const Matrix3Xd& m, const char* what) const;

  Matrix3Xd m_positions;
  Matrix3Xd m_velocities;
  CorotatedElasticity m_elasticity;
  Material m_material;
  Matrix3Xd m_rest;
  std::vector<double> m_tet_mass;            ///< #T [kg]: density × rest volume × solid fraction
  std::vector<double> m_solid_fraction;      ///< #T, to recompute the masses for a new density
  std::vector<Vec4> m_corner_weight;         ///< #T, each sums to 1
  Eigen::VectorXd m_mass;                    ///< #N lumped masses [kg]
  std::vector<std::uint8_t> m_pinned;  ///< 0 free, 1 pinned, kHeld held (hold())
  static constexpr std::uint8_t kHeld = 2;
  BlockSystem m_system;                      ///< A's pattern, assembly and product
  LaggedCholesky m_factor;                   ///< the direct solve's factor, or the lagged preconditioner
  LooseNodes m_loose_nodes;                  ///< eliminated afresh each step beside the lagged factor
  int m_loose_node_slots = 0;                ///< the StepSettings value m_loose_nodes was found with
  bool m_pattern_dirty = true;               ///< a split or pin changed the connectivity
  int m_factorizations = 0;
  std::vector<Mat34> m_tet_rhs;              ///< per tet: f + (β + h) K v at its corners
  std::vector<Mat34> m_tet_damping_change;   ///< multiply_hessian(): per tet (K(x) − K₀) x at its corners
  /// Conjugate gradients' warm start. After two solves in a row at the same dt with no
  /// contact correction between (m_smooth_solves ≥ 2) it is the linear extrapolation
  /// 2 Δv_last − Δv_previous: a smoothly moving body (a sagging cantilever, free flight)
  /// then needs one iteration where the last Δv alone needed two (987-tet bunny cage:
  /// 1.92 → 1.03 iterations per step; 10,024 tets: 2.02 → 1.45). Otherwise it is the
  /// last Δv (with any contact correction in it): measured on the bunny scene,
  /// extrapolating across contact steps, or from Δv without the corrections, tripled
  /// the lagged factor's refreshes (11 → 37 and 69) without saving iterations.
  Matrix3Xd m_last_dv;                       ///< per node: the last step's Δv
  Matrix3Xd m_previous_dv;                   ///< per node: the Δv before it
  int m_smooth_solves = 0;                   ///< solves in a row since a contact correction, pin or dt change (capped at 2)
  double m_last_dt = 0.0;
  /// What the last solve's system was, for multiply_system and precondition_system.
  enum class SystemForm : std::uint8_t { None, Assembled, MatrixFree } m_system_form = SystemForm::None;
  enum class SystemInverse : std::uint8_t { None, Factor, RotatedFactor, Jacobi } m_system_inverse = SystemInverse::None;
  double m_system_k_scale = 0.0, m_system_m_scale = 0.0;
  Eigen::VectorXd m_inverse_diagonal;        ///< Jacobi's preconditioner
  int m_iterations = 0;
  ElementBuffers m_elements;
  ElementBuffers m_start_elements;           ///< solve_exactly(): the step's start evaluation (K₀)
  PhaseTimes m_phase_times;
};

}  // namespace fissure::sim
