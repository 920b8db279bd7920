#pragma once
/// A scene in motion: deformable bodies, projectiles and static obstacles, stepped
/// together. Each step: evaluate every body's tets → fracture → implicit solve →
/// collisions. A feature that is off costs nothing: without fracture no stresses are
/// kept, without collisions no points are swept.

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "player/sim/contacts/collision.h"
#include "player/sim/contacts/pile.h"
#include "player/sim/energy_budget.h"
#include "player/sim/fracture.h"
#include "player/sim/implicit_integrator.h"
#include "player/sim/contacts/stand_in_spheres.h"

namespace fissure::sim {

enum class CollisionPoints { Spheres, RenderVertices };

/// Everything needed to build one body; the app fills it from a bundle and a scene.
struct BodyDescription {
  std::string name;
  Matrix3Xd rest;          ///< 3×#N cage nodes in world space at rest [m]
  Matrix3Xd positions;     ///< 3×#N where the nodes start (empty: at rest)
  Matrix4Xu tets;          ///< 4×#T, positively oriented
  Material material;
  double toughness = std::numeric_limits<double>::infinity();  ///< [N]
  ContactMaterial contact;
  std::optional<MassDistribution> mass;  ///< solid fraction and centre of mass per tet
  EmbeddedPoints spheres;        ///< the bake's collision spheres (empty: see World)
  /// The bake's reserve spheres and each one's cover tet (kInvalidIndex: none), held
  /// back until a split parts the two (stand_in_spheres.h).
  EmbeddedPoints reserve_spheres;
  std::vector<TetIndex> reserve_cover;
  EmbeddedPoints vertices;       ///< every render vertex (radius 0), for the exact mode and penetration
  std::vector<NodeIndex> pinned;
  Matrix3Xd velocity;            ///< 3×#N initial node velocities (empty: at rest)
};

/// Which energy-gaining substeps World solves again exactly (WorldSettings::exact_when_gaining).
enum class ExactResolve : std::uint8_t { Never, Solve, SolveAndContacts };

struct WorldSettings {
  StepSettings step;
  double min_dt = 0;  ///< > 0: a step whose solve fails is retried as two halves, down to this
  /// A step longer than this is taken as equal substeps no longer than it, each with its
  /// own fracture and contacts (0: never). Scenes default to 1/60 s (formats/scene.h):
  /// the sample bunny hit by its ball keeps the energy bound at 1/60 s and gains ×1.3e13
  /// at 1/30 s (docs/decisions/0030-energy-check-per-run.md). The world itself steps
  /// what it is told.
  double max_substep = 0.0;
  bool fracture = false;
  int max_splits_per_step = 64;  ///< per substep: each substep runs fracture
  bool collisions = true;
  bool self_collision = false;
  CollisionPoints collision_points = CollisionPoints::Spheres;
  /// The contacts' tuning values (contact_settings.h); a scene sets contact_iterations
  /// and contact_sweeps from its [solver] table.
  ContactSettings contacts;
  /// Each fragment's rigid rotation within a step moves on an arc, not a line
  /// (rigid_rotation.h); off: plain backward Euler, for comparison.
  bool rotate_on_arcs = true;
  /// Restitution gives back at most what a substep would otherwise lose (World::collide);
  /// off: Newton's rule on every contact alone, for comparison.
  bool restitution_within_budget = true;
  /// In a pile (pile.h: a contact response ran long, or swept its debris to the cap,
  /// within contacts.sparse_block_memory substeps), after a substep whose inelastic
  /// answer ended above its budget anyway, the next substep answers inelastically first
  /// and restitution only if there is room (World::collide); off: restitution first
  /// always, for comparison.
  bool inelastic_first_in_piles = true;
  /// A substep that ends above its energy budget (its start's energy plus what was put in)
  /// is solved again exactly (ImplicitIntegrator::solve_exactly) where its linear solve
  /// gained: from that answer turned on arcs, with its contacts answered again (Solve); and
  /// also where its contact response gained, with that response's impulses held
  /// (SolveAndContacts). See World::solve_exactly_if_gaining for what each fixes and what
  /// the second still breaks. Paid only in substeps that would otherwise create energy.
  ExactResolve exact_when_gaining = ExactResolve::Solve;
  int exact_iterations = 30;  ///< Newton iterations at most per body and exact substep
  /// A substep whose gain is at most this share of what the run has dissipated so far
  /// (the run's bound less the substep's own) is not solved again exactly: the run's
  /// bound, which the halvings below keep, still holds, and each such substep can spend
  /// at most this share of what is left. 0: every gain is solved again. The re-solve is
  /// Newton iterations over the whole body: on the sample in the 10,024-tet cage, seven
  /// gains of 6 µJ–11 mJ (at most 0.04 % of the run's 30 J dissipated) took 0.4–1.7 s
  /// each, the run's slowest steps (issue 42;
  /// docs/decisions/0057-exact-resolve-above-a-share-of-what-was-dissipated.md).
  double exact_gain_share = 0.01;
  /// A substep that still ends above its energy budget after the exact re-solve, and
  /// above all the world was given, has its chips of fewer tets than this that gained
  /// energy in it moved rigidly (World::move_gaining_chips_rigidly): their shape at the
  /// substep's start moved and turned, their velocities made rigid. A few-tet fragment
  /// of a nearly incompressible material is where the linear solve runs away
  /// (ν = 0.4999: 143 kJ from 37.6 J given, 14.3 J of it in one tet of a 3-tet chip a
  /// split had just made), and no halving of the step stops it
  /// (docs/decisions/0075-chips-that-gain-move-rigidly.md). 0: never.
  int rigid_when_gaining_below = 8;
  /// A substep that still ends above its energy budget after the repairs above, and
  /// above all the world was given (its energy when built plus what was put in since),
  /// is taken again as two halves from its start, at most this many times in a row (so
  /// down to dt / 2^energy_halvings, and never below min_dt); 0: never. Step-size
  /// control with the run's energy bound as the tolerance: what the repairs leave is the
  /// large step's own error (contact corrections moved on lines, light stiff fragments
  /// landing at km/s), which shrinks with the step. Gains that stay within what earlier
  /// steps dissipated are let through: on the sample scene the strict per-substep test
  /// halved 492 substeps for gains of at most 2.7 mJ, doubling its cost, in a run that
  /// never came within 0.6 J of its bound. 6 keeps both stability grids within the bound
  /// in every case (docs/decisions/0033-halving-substeps-that-gain.md).
  int energy_halvings = 6;
  /// Islands of fragments at rest are held still until something closes on them
  /// (sleeping.h); speed 0: never.
  SleepSettings sleep;
};

/// How a step ended. A step never throws for a numerical outcome: it says what
/// happened, and a failed step leaves the world exactly as it was before it.
enum class StepOutcome : std::uint8_t {
  Converged,    ///< one solve per body at dt (a CG solve may have hit its cap: see StepReport::unconverged)
  Substepped,   ///< taken in substeps: dt above max_substep, or a failed solve retried as halves (min_dt)
  SolveFailed,  ///< a solve failed even at the smallest dt allowed: the world is unchanged
  NonFinite,    ///< the step produced a non-finite position or velocity: the world is unchanged
};

struct StepStatus {
  StepOutcome outcome = StepOutcome::Converged;
  Index body = kInvalidIndex;                ///< the body whose solve failed or went non-finite (kInvalidIndex: a projectile)
  SolveStatus solve = SolveStatus::Converged;  ///< SolveFailed: why the body's solve failed
  double time = 0;                           ///< [s] start of the failed step
  double dt = 0;                             ///< [s] the step that failed (the smallest tried)
  [[nodiscard]] bool ok() const { return outcome == StepOutcome::Converged || outcome == StepOutcome::Substepped; }
};

/// A failed status in words, for people: what failed, where, when and why.
struct StepFailure {
  std::string message;  ///< e.g. "at t = 0.25 s, body 'bunny': the implicit solve failed (…) at dt = 0.01 s"
  std::string hint;     ///< what to try
};

[[nodiscard]] const char* to_string(StepOutcome outcome);

/// One body's energy [J]; gravity's relative to the origin.
struct BodyEnergy {
  double kinetic = 0, elastic = 0, gravity = 0;
  [[nodiscard]] double total() const { return kinetic + elastic + gravity; }
};

/// A split as a recording keeps it, for replaying (World::redo_splits).
struct RecordedSplit {
  NodeIndex node = kInvalidIndex, added = kInvalidIndex;
  std::span<const TetIndex> moved;  ///< the tets that took `added` in `node`'s place
};

/// What one step did, for reports.
struct StepReport {
  StepStatus status;
  double forces = 0, assembly = 0, solve = 0, fracture = 0, collisions = 0;  ///< [s] wall clock
  double total = 0;                 ///< [s] wall clock of the whole step, phases and what lies between
  int substeps = 1;                 ///< > 1 when adaptive stepping halved dt
  int solver_iterations = 0;        ///< summed over bodies and substeps
  int factorizations = 0;           ///< numeric Cholesky factorizations, summed likewise
  bool unconverged = false;         ///< a CG solve hit the iteration cap
  std::vector<std::pair<Index, NodeSplit>> splits;      ///< (body, split)
  std::vector<std::pair<Index, TetFace>> exposed;       ///< (body, face newly on the boundary)
  ContactCounts contacts;
  /// The smallest share of the contacts' restitution a substep kept: below 1 when the
  /// full restitution would have ended it above its energy budget (World::collide).
  double restitution_kept = 1.0;
  int exact_substeps = 0;    ///< substeps solved again exactly (WorldSettings::exact_when_gaining)
  int exact_iterations = 0;  ///< their Newton iterations, summed over bodies
  int energy_halvings = 0;   ///< substeps taken again as two halves because they gained energy
  int chips_moved_rigidly = 0;  ///< chips moved rigidly because they gained (WorldSettings::rigid_when_gaining_below)
  int exact_substeps_rejected = 0;  ///< of those, the ones whose contacts then gained more: the linear answer kept
  int stand_in_spheres = 0;  ///< spheres given to tets fracture exposed: stand-ins and the bake's reserve (stand_in_spheres.h)
  std::size_t fragments_asleep = 0;  ///< held still after the step (sleeping.h)
  int retaken_to_wake = 0;  ///< times the step was taken again because it closed on a sleeping island
};

/// What a renderer, recorder or viewer may read of one body between steps
/// (docs/architecture.md, "The sim/render boundary: World::frame"). Valid until the next step.
struct BodyFrame {
  const Matrix3Xd& positions;           ///< 3×#N now [m]
  const Matrix3Xd& previous_positions;  ///< 3×#N at the start of the last step (a split node: its source's)
  const Matrix4Xu& tets;                ///< 4×#T, after splits
  /// Per tet, the deformation gradient F at `positions` (end of step): a renderer turns
  /// rest normals with its cofactor (F⁻ᵀ up to scale), the rotation alone with its polar part.
  std::span<const Mat3> deformation;
  std::span<const FaceState> faces;     ///< 4 per tet, face k opposite corner k
  std::span<const Index> fragment;      ///< per tet
  std::uint64_t topology_version;       ///< changes exactly when `tets` does
};

class Body {
 public:
  Body(std::string name, std::unique_ptr<ImplicitIntegrator> integrator, FractureTopology topology,
       FractureSettings fracture, ContactMaterial contact, EmbeddedPoints spheres, EmbeddedPoints vertices);

  std::string name;
  FractureTopology topology;
  FractureSettings fracture;
  ContactMaterial contact;
  EmbeddedPoints spheres;
  EmbeddedPoints vertices;
  /// Pairs of the collision points in use that a split left overlapping (split_overlaps.h).
  SplitOverlaps split_overlaps;

  [[nodiscard]] const ImplicitIntegrator& integrator() const { return *m_integrator; }
  ImplicitIntegrator& integrator() { return *m_integrator; }
  [[nodiscard]] const EmbeddedPoints& collision_points(CollisionPoints mode) const {
    return mode == CollisionPoints::Spheres ? spheres : vertices;
  }

 private:
  std::unique_ptr<ImplicitIntegrator> m_integrator;  ///< pinned in memory (see ImplicitIntegrator)
};

class World {
 public:
  /// Throws fissure::Error on invalid input. A body without baked spheres gets one
  /// sphere per tet, at its centroid and inside the tet, so collisions still work; a
  /// tet with solid but no sphere gets one when fracture exposes it (stand_in_spheres.h).
  World(std::vector<BodyDescription> bodies, Environment environment, std::vector<Projectile> projectiles,
        WorldSettings settings);

  /// Advances by settings.step.dt; report.status says how it went. On SolveFailed or
  /// NonFinite nothing changed: time, positions, velocities, splits, projectiles and
  /// the solvers' warm starts are as before the call.
  StepReport step();

  [[nodiscard]] double time() const { return m_time; }
  [[nodiscard]] const std::vector<Body>& bodies() const { return m_bodies; }
  [[nodiscard]] const std::vector<Projectile>& projectiles() const { return m_projectiles; }
  [[nodiscard]] const Environment& environment() const { return m_environment; }
  [[nodiscard]] const WorldSettings& settings() const { return m_settings; }
  /// How many equal substeps a step is taken in (WorldSettings::max_substep), before any
  /// halving of a failed solve.
  [[nodiscard]] int planned_substeps() const;
  /// Body `body` as it is now. Its deformation gradients are computed on the first call
  /// after a step that asks for them (one pass over the tets), so a world nobody reads
  /// them from never pays; without them `deformation` is empty.
  [[nodiscard]] BodyFrame frame(Index body, bool with_deformation = true) const;
  /// Words for a status this world returned (ok statuses too).
  [[nodiscard]] StepFailure explain(const StepStatus& status) const;
  /// Replaces a body's node velocities (3×#N, finite): an external push, such as a
  /// viewer's drag or a test's kick. It is work put into the world.
  void set_velocities(Index body, const Matrix3Xd& velocities);
  /// A body's new material and toughness [N] from the next step on (a viewer's live
  /// sliders). Throws fissure::Error for an invalid value; then nothing changed.
  void set_material(Index body, const Material& material, double toughness);
  /// Adds a projectile that enters at the next step (a viewer's shot). Its kinetic
  /// energy is work put into the world. Throws fissure::Error for a non-finite state,
  /// a radius or mass that is not positive.
  void add_projectile(Projectile projectile);
  /// Applies new settings from the next step on (a viewer's live dt, tolerance or
  /// solver). Throws fissure::Error for a dt that is not positive and finite.
  void set_settings(const WorldSettings& settings);

  // Replay (player/app/replay.h: a viewer scrubbing a recorded run). The world is posed,
  // not stepped: topology changes exactly as fracture made it, positions as recorded.
  /// Applies `splits` to a body in order, each exactly as fracture did. Throws
  /// fissure::Error, before changing anything, when one does not fit the body (a moved
  /// tet that does not hold the node, or an added node that is not the next one).
  void redo_splits(Index body, std::span<const RecordedSplit> splits);
  /// Undoes `splits`, the body's newest, last first.
  void undo_splits(Index body, std::span<const RecordedSplit> splits);
  /// Places a body's nodes (3×#N for its current node count); its velocities become 0.
  void pose(Index body, const Matrix3Xd& positions);
  /// Places the clock and replaces the projectiles' states (as many as the world has).
  void pose(double time, std::span<const Projectile> projectiles);

  [[nodiscard]] double kinetic_energy() const;
  [[nodiscard]] double elastic_energy() const;
  [[nodiscard]] double potential_energy() const;  ///< gravity, relative to the origin
  [[nodiscard]] double total_energy() const { return kinetic_energy() + elastic_energy() + potential_energy(); }
  [[nodiscard]] BodyEnergy body_energy(Index body) const;
  /// The energy put into the world from outside since it was built [J]: each projectile's
  /// kinetic and gravity energy as it is launched (a scene's or a viewer's), and the
  /// kinetic energy set_velocities changed. The physics may only lose energy, so the
  /// total energy never exceeds its start plus this (issue 16: Diagnostics checks it).
  [[nodiscard]] double energy_put_in() const { return m_energy.put_in(); }
  [[nodiscard]] Vec3 linear_momentum() const;
  [[nodiscard]] Vec3 angular_momentum() const;    ///< about the origin
  [[nodiscard]] Index fragment_count() const;     ///< summed over bodies
  /// Deepest penetration [m] of any body's collision spheres, or of any render vertex,
  /// into obstacles and projectiles: the second is what a viewer sees (thesis VI.B.1).
  [[nodiscard]] double sphere_penetration() const;
  [[nodiscard]] double vertex_penetration() const { return deepest_vertex().hit.depth; }
  /// Where render vertices sink deepest: the vertex, its body and fragment, and the
  /// obstacle it is in (hit.kind None, depth 0, when none is in any).
  struct DeepestVertex {
    Index body = 0, vertex = 0, fragment = 0;
    ObstacleHit hit;
  };
  [[nodiscard]] DeepestVertex deepest_vertex() const;

 private:
  /// The state before a step, to put back when it fails.
  struct Checkpoint {
    double time = 0;
    std::vector<ImplicitIntegrator::Checkpoint> bodies;
    std::vector<Projectile> projectiles;
    ContactImpulses impulses;
    std::vector<SplitOverlaps> split_overlaps;  ///< per body
    std::vector<std::size_t> sphere_counts;     ///< per body, before stand-ins were added
    double energy_put_in = 0;
  };
  StepStatus advance(double dt, StepReport& report, int depth);
  /// What a substep's start holds beyond the bodies' checkpoint (solve_bodies).
  struct SubstepStart {
    std::vector<Projectile> projectiles;
    double energy_put_in = 0;
  };
  /// Puts the substep back to its start and takes it as two halves, one level deeper.
  StepStatus take_again_as_halves(const SubstepStart& start, double dt, StepReport& report, int depth);
  void fracture_bodies(StepReport& report);
  /// Records the collision points that `b`'s splits left overlapping across a new
  /// fragment boundary (split_overlaps.h); `fragment_before`: its tets' fragments before.
  void record_split_overlaps(Body& b, const std::vector<Index>& fragment_before) const;
  /// Solves every body at dt; on a failure, puts the solved ones back where they were.
  StepStatus solve_bodies(const StepSettings& step, StepReport& report);
  void launch_and_move_projectiles(double dt);
  void collide(double dt, StepReport& report);
  /// What sleeping sees of the bodies.
  [[nodiscard]] std::vector<SleepBody> sleep_bodies();
  /// The most the substep may end with: its start's energy plus what was put in since,
  /// and rounding [J] (EnergyBudget::substep_limit). Measures the bodies' energy at the
  /// substep's start on first use: the elastic part is a polar decomposition per tet.
  [[nodiscard]] double substep_energy_limit();
  /// The bodies' energy at the substep's start into m_energy, unless it is there.
  void measure_substep_start();
  /// Answers `contacts` again inelastically and keeps the largest blend of the two
  /// answers within `budget` [J] (the bodies hold the full restitution's answer).
  void keep_restitution_within(StepContacts& contacts, double budget, StepReport& report);
  /// The same, the other way round: the bodies hold the inelastic answer. Over `budget`,
  /// it stays and restitution is not tried; within it, `contacts` are answered again
  /// with full restitution and the largest blend within `budget` kept.
  void add_restitution_within(StepContacts& contacts, double budget, StepReport& report);
  /// The largest share s ∈ [0, 1] for which the blend of m_inelastic_motion and
  /// m_bounced_motion (energies `inelastic` ≤ budget < `bounced`) keeps `budget`.
  double largest_share_within(double budget, double inelastic, double bounced);
  /// Every body's and projectile's motion, to try the contact response twice in a substep.
  struct Motion {
    std::vector<ImplicitIntegrator::Motion> bodies;
    std::vector<Projectile> projectiles;
  };
  void save_motion(Motion& out) const;
  void restore_motion(const Motion& motion);
  /// Restores a + s (b − a).
  void restore_blend(const Motion& a, const Motion& b, double s);
  /// Each fragment's rigid rotation since `from` (per body), on an arc (rigid_rotation.h).
  void rotate_fragments_on_arcs(const std::vector<Matrix3Xd>& from);
  /// When the substep ended above its energy budget: back to the linear solve's answer
  /// (m_linear_motion), every body solved exactly, projectiles and contacts again.
  /// Returns the energy the substep ends with [J].
  double solve_exactly_if_gaining(const StepSettings& step, StepReport& report);
  /// Whether a substep of `dt` at halving depth `depth` that ends above its energy
  /// budget is taken again as two halves (WorldSettings::energy_halvings, min_dt).
  [[nodiscard]] bool halves_when_gaining(double dt, int depth) const;
  /// The solve gained: every body solved exactly, then projectiles and contacts again.
  void resolve_exactly(const StepSettings& step, StepReport& report);
  /// The contacts gained: every body solved exactly with the contacts' impulses held.
  void resolve_contacts_exactly(const StepSettings& step, StepReport& report);
  void solve_bodies_exactly(const StepSettings& step, StepReport& report, const std::vector<Eigen::VectorXd>* impulses);
  /// Back to the substep's linear answer after contacts and arcs (m_linear_end_motion).
  void keep_linear_answer();
  /// The substep ends with `energy` above `limit` [J]: the fewest chips (fragments of
  /// fewer tets than WorldSettings::rigid_when_gaining_below), largest gain first, whose
  /// gains since the substep's start cover the excess are moved rigidly from it. Kept
  /// only where that lowers the energy. Returns the energy the substep ends with [J].
  double move_gaining_chips_rigidly(double energy, double limit, StepReport& report);
  /// A chip's gain since the substep's start [J] (kinetic, strain and gravity).
  struct ChipGain {
    double joules = 0;
    std::size_t body = 0;
    Index fragment = 0;
  };
  /// The chips that gained, largest gain first; `chips` gets, per body and fragment,
  /// nonzero for each chip.
  std::vector<ChipGain> chip_gains(std::vector<std::vector<std::uint8_t>>& chips);
  /// Per node of body `bi`, its fragment, into m_node_fragment.
  void find_node_fragments(std::size_t bi);
  /// The first body with a non-finite position or velocity (kInvalidIndex: a projectile).
  [[nodiscard]] std::optional<Index> first_non_finite() const;
  void roll_back(const StepReport& report);
  void keep_previous_positions(const StepReport& report);

  std::vector<Body> m_bodies;
  /// Per body, the spheres its tets get when exposed: stand-ins for bare tets and the
  /// bake's reserve (collision mode Spheres only: the render-vertex mode is exact to the
  /// render surface, and leaves interior tets bare).
  std::vector<StandInSpheres> m_stand_ins;
  Environment m_environment;
  std::vector<Projectile> m_projectiles;
  WorldSettings m_settings;
  double m_time = 0;
  std::vector<Matrix3Xd> m_start_positions;  ///< per body, at the start of the current (sub)step
  std::vector<Vec3> m_projectile_start;      ///< likewise per projectile
  Motion m_free_motion, m_bounced_motion, m_inelastic_motion, m_blend_motion;  ///< collide()'s scratch
  Motion m_linear_motion;  ///< the bodies at the linear solve's answer, the projectiles before the substep
  std::vector<Matrix3Xd> m_exact_positions;  ///< per body, the exact solve's answer before contacts
  Motion m_linear_end_motion;                ///< the substep's linear answer after contacts and arcs
  Motion m_contact_motion;                   ///< the substep's linear answer after contacts, before arcs
  std::vector<Eigen::VectorXd> m_held_impulses;  ///< per body, the contact response's impulses (system rows)
  ContactImpulses m_linear_end_impulses;     ///< and the contact impulses it left
  double m_linear_end_put_in = 0;            ///< and energy_put_in() after it
  std::vector<Matrix3Xd> m_previous_positions;  ///< per body, at the start of the last whole step
  ContactImpulses m_contact_impulses;  ///< the last step's, to warm-start the next
  Pile m_pile;  ///< whether the last substeps' responses met a pile (pile.h)
  /// The last substep that restituted ended above its budget even inelastically: the
  /// next answers inelastically first (collide()).
  bool m_restitution_futile = false;
  std::vector<Index> m_node_fragment;  ///< scratch for rotate_fragments_on_arcs and find_node_fragments
  Motion m_unrepaired_motion;          ///< move_gaining_chips_rigidly's scratch
  Sleeping m_sleeping;
  std::vector<Touch> m_touches;  ///< the last substep's contacts, for sleeping
  std::vector<Index> m_fragment_before;  ///< scratch for fracture_bodies: a body's tet fragments before its splits
  Checkpoint m_checkpoint;
  std::vector<ImplicitIntegrator::Checkpoint> m_substep_checkpoint;  ///< solve_bodies' scratch
  std::uint64_t m_steps = 0;
  EnergyBudget m_energy;  ///< what the run and the substep may hold (energy_budget.h)
  mutable std::vector<std::vector<Mat3>> m_deformation;   ///< per body, frame()'s cache
  mutable std::vector<std::uint64_t> m_deformation_step;  ///< per body, the step it is of (+1; 0: none)
};

}  // namespace fissure::sim
