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

#include "player/sim/body.h"
#include "player/sim/contacts/collision.h"
#include "player/sim/contacts/pile.h"
#include "player/sim/contacts/stand_in_spheres.h"
#include "player/sim/energy_guard.h"
#include "player/sim/fracture.h"
#include "player/sim/implicit_integrator.h"
#include "player/sim/step_report.h"
#include "player/sim/world_settings.h"

namespace fissure::sim {

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
  [[nodiscard]] double energy_put_in() const { return m_guard.budget().put_in(); }
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
  /// The bodies and projectiles lent to the energy guard for one call.
  [[nodiscard]] GuardedWorld guarded();
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
  std::vector<Matrix3Xd> m_previous_positions;  ///< per body, at the start of the last whole step
  ContactImpulses m_contact_impulses;  ///< the last step's, to warm-start the next
  Pile m_pile;  ///< whether the last substeps' responses met a pile (pile.h)
  std::vector<Index> m_node_fragment;  ///< scratch for the arcs
  Sleeping m_sleeping;
  std::vector<Touch> m_touches;  ///< the last substep's contacts, for sleeping
  std::vector<Index> m_fragment_before;  ///< scratch for fracture_bodies: a body's tet fragments before its splits
  Checkpoint m_checkpoint;
  /// Per body, the substep's start as solve_bodies saved it: what take_again_as_halves
  /// restores, and what the energy guard measures and re-solves from (GuardedWorld::substep_start).
  std::vector<ImplicitIntegrator::Checkpoint> m_substep_checkpoint;
  std::uint64_t m_steps = 0;
  EnergyGuard m_guard;  ///< the substep's energy budget and its repairs (energy_guard.h)
  mutable std::vector<std::vector<Mat3>> m_deformation;   ///< per body, frame()'s cache
  mutable std::vector<std::uint64_t> m_deformation_step;  ///< per body, the step it is of (+1; 0: none)
};

}  // namespace fissure::sim
