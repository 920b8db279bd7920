#pragma once
/// Scene files for the player: which bundles to load, where, with which material, the
/// static environment, projectiles and solver settings. TOML, documented key by key in
/// docs/scene-example.toml. Units are SI throughout (m, kg, s, N, Pa).
///
/// The reader validates everything it can without loading bundles: unknown keys, wrong
/// types, out-of-range values. Every error is a fissure::Error whose message starts with
/// "<file>:<line>:" and names the full dotted key (`object[0].material.poisson_ratio`);
/// the hint says what is allowed. Whether bundles exist, and whether pinned node indices
/// fit them, is the app's check: it is the one that opens them.
///
/// The TOML parser stays inside scene.cpp; this header needs only Eigen and std.

#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/types.h"

namespace fissure::formats {

/// Rolling resistance μ_r of every contact material unless a scene sets it: a contact
/// resists its sides' relative spin with a couple of at most μ_r r times its normal force
/// (r: the sphere's radius; player/sim/contacts/rolling_resistance.h says why it is needed).
constexpr double kDefaultRollingResistance = 0.0;
/// [m/s] fragments slower than this for SceneSolverSettings::sleep_time sleep.
constexpr double kDefaultSleepSpeed = 0.0;

/// Material of one object. Elastic constants feed the corotated linear model.
struct SceneMaterial {
  double density = 1000;          ///< [kg/m³], > 0
  double youngs_modulus = 1e6;    ///< [Pa], > 0
  double poisson_ratio = 0.3;     ///< [-], in [0, 0.5)
  /// [N] threshold on the largest eigenvalue of a node's separation tensor; ≥ 0.
  /// Infinity (the default) means the object never fractures.
  double toughness = std::numeric_limits<double>::infinity();
  double rayleigh_mass = 0;       ///< [1/s] mass-proportional damping α (C = αM + βK), ≥ 0
  double rayleigh_stiffness = 0;  ///< [s] stiffness-proportional damping β, ≥ 0
  double restitution = 0.2;       ///< [-] in [0, 1]
  double friction = 0.5;          ///< [-] Coulomb coefficient, ≥ 0
  double rolling_resistance = kDefaultRollingResistance;  ///< [-] ≥ 0, see sim::ContactMaterial
};

/// Axis-aligned box in world coordinates (after the object's transform); the nodes of
/// the object inside it are fixed in place.
struct ScenePinBox {
  Vec3 min = Vec3::Zero();  ///< [m]
  Vec3 max = Vec3::Zero();  ///< [m], > min in every component
};

/// One bundle placed in the world. The transform applies scale, then rotation, then
/// translation to the bundle's rest positions.
struct SceneObject {
  std::string name;                 ///< for logs and the UI; defaults to the bundle's file stem
  std::filesystem::path bundle;     ///< resolved against the scene file's folder (unless absolute)
  Vec3 translation = Vec3::Zero();  ///< [m]
  Vec3 rotation_axis = Vec3::UnitZ();  ///< unit length (normalized by the reader)
  double rotation_degrees = 0;      ///< [°] right-handed about rotation_axis
  double scale = 1;                 ///< [-] uniform, > 0
  Vec3 velocity = Vec3::Zero();     ///< [m/s] initial, of every node
  Vec3 angular_velocity = Vec3::Zero();  ///< [rad/s] initial, about the object's rest centroid
  SceneMaterial material;
  std::vector<ScenePinBox> pin_boxes;  ///< in world coordinates after the transform
  std::vector<Index> pin_nodes;        ///< cage node indices, concatenated over all [[object.pin]]
  std::optional<Vec3> color;           ///< surface colour, linear RGB in [0, 1]; none: the player's default
  std::optional<Vec3> interior_color;  ///< colour of the walls fracture opens; none: the player's default
  int line = 0;                        ///< line of the object's [[object]] header, for app errors
};

/// Static axis-aligned box obstacle.
struct SceneBox {
  Vec3 min = Vec3::Zero();  ///< [m]
  Vec3 max = Vec3::Zero();  ///< [m], > min in every component
  double restitution = 0.2;
  double friction = 0.5;
  double rolling_resistance = kDefaultRollingResistance;
};

/// Static sphere obstacle.
struct SceneSphere {
  Vec3 center = Vec3::Zero();  ///< [m]
  double radius = 0;           ///< [m], > 0
  double restitution = 0.2;
  double friction = 0.5;
  double rolling_resistance = kDefaultRollingResistance;
};

/// Infinite static plane n·x = offset; the solid side is n·x < offset.
struct SceneGround {
  bool enabled = false;           ///< true when the scene has an [environment.ground] table
  Vec3 normal = Vec3::UnitZ();    ///< unit length (normalized by the reader)
  double offset = 0;              ///< [m]
  double restitution = 0.2;
  double friction = 0.5;
  double rolling_resistance = kDefaultRollingResistance;
};

/// Rigid sphere launched at the objects at launch_time.
struct SceneProjectile {
  Vec3 position = Vec3::Zero();  ///< [m] at launch_time
  Vec3 velocity = Vec3::Zero();  ///< [m/s] at launch_time
  double radius = 0;             ///< [m], > 0
  double mass = 0;               ///< [kg], > 0
  double launch_time = 0;        ///< [s] simulation time of the launch, ≥ 0
  double restitution = 0.5;
  double friction = 0.3;
  double rolling_resistance = kDefaultRollingResistance;
  int line = 0;                  ///< line of the [[projectile]] header
};

enum class SceneSolver { Direct, ConjugateGradient };
enum class ScenePreconditioner { Cholesky, Jacobi };
enum class SceneStiffness { Warped, Exact };
enum class SceneRotation { Arc, Line };
enum class SceneExact { Never, Solve, Contacts };
enum class SceneCollisionMode { Spheres, Vertices };

struct SceneSolverSettings {
  double dt = 1.0 / 240;  ///< [s] time step (the largest one when adaptive), in (0, 1]
  double min_dt = 0;      ///< [s] 0 = fixed dt; else adaptive between min_dt and dt
  /// [s] a longer dt is taken in equal substeps no longer than this; 0 = never. 1/60 s:
  /// the sample bunny hit by its ball keeps the energy bound at dt = 1/60 s and gains
  /// ×1.3e13 at 1/30 s (docs/decisions/0030-energy-check-per-run.md).
  double max_substep = 1.0 / 60.0;
  SceneSolver solver = SceneSolver::ConjugateGradient;
  /// [-] relative residual of the linear solve, in (0, 1). 1e-4: at dt = 1/240 the
  /// solver then adds under 1% of the time-step error (BENCHMARKS.md, trade-off sweep);
  /// tighter buys nothing measurable and costs iterations.
  double tolerance = 1e-4;
  int max_iterations = 500;  ///< CG iterations per solve, ≥ 1
  ScenePreconditioner preconditioner = ScenePreconditioner::Cholesky;  ///< for "cg"
  int refactor_iterations = 8;  ///< "cholesky": refactor after a solve taking more iterations (0085), ≥ 1
  /// "cholesky": nodes in at most this many tets are eliminated afresh each step beside
  /// the lagged factor (sim::LooseNodes), 0 … 8; 0 = none (record 0084).
  int loose_node_slots = 0;
  SceneStiffness stiffness = SceneStiffness::Warped;  ///< stiffness-warped or exact corotated tangent
  /// How a fragment's rigid turn within a step is applied (sim/rigid_rotation.h).
  SceneRotation rotation = SceneRotation::Arc;
  /// Which substeps that gain energy are solved again to convergence (Newton iterations,
  /// sim::WorldSettings::exact_when_gaining): where the linear solve gained ("solve"),
  /// also where the contact response gained ("contacts"), or none ("never").
  SceneExact exact_when_gaining = SceneExact::Solve;
  /// A gain smaller than this share of what the run has dissipated so far is left to the
  /// run's bound instead of an exact re-solve (sim::WorldSettings::exact_gain_share);
  /// 0 ≤ share ≤ 1, 0 = re-solve every gain.
  double exact_gain_share = 0.01;
  /// A substep that still ends with more energy than it had after the repairs above is
  /// taken again as two halves, at most this many times in a row
  /// (sim::WorldSettings::energy_halvings); 0 = never. 6: the stability grids keep the
  /// energy bound in every case (docs/decisions/0033-halving-substeps-that-gain.md).
  int energy_halvings = 6;
  /// A substep still above its energy budget after the exact re-solve has its chips of
  /// fewer tets than this that gained energy moved rigidly from its start
  /// (sim::WorldSettings::rigid_when_gaining_below); 0 = never, every fragment solved as
  /// FEM in every substep (the thesis's model). Integer 0 … 1e6.
  int rigid_when_gaining_below = 8;
  /// The contact response's outer iterations at most per answer, 1 … 64
  /// (sim::ContactSettings::iterations). A pile of hundreds of fragments uses them
  /// all: at 4 the bunny at toughness 0 spends 28 % less in collisions with no deeper
  /// contacts, but a 1000 m/s hit on a light bar then leaves spheres metres deep, so 8
  /// stays the default (docs/decisions/0034-contact-iterations-default-8.md).
  int contact_iterations = 8;
  /// A contact response among small fragments and projectiles only is answered by
  /// sequential impulses, at most this many sweeps, 0 … 1024
  /// (sim::ContactSettings::sequential_impulse_sweeps); 0 = always the augmented
  /// Lagrangian, the answer of every response before
  /// (docs/decisions/0072-sequential-impulses-for-debris.md).
  int contact_sweeps = 16;
  /// A large fragment at rest, no projectile on it (its contacts asking for at most this
  /// velocity change, or twice one step of gravity where that is more, its motion rigid
  /// to within it) has its contacts answered as a rigid body's, 0 … 10 [m/s]
  /// (sim::ContactSettings::rigid_resting_speed); 0 = never, every fragment deformable
  /// in every response (the thesis's model). Unset: rigid_resting_speed(Scene).
  std::optional<double> rigid_resting_speed;
  /// A fragment of fewer tets than this moves as a rigid body, its strain frozen at what
  /// it was when it broke free (sim::ContactSettings::rigid_fragments_below); 0 = none,
  /// every fragment deformable (the thesis's model). Integer 0 … 1e6.
  int rigid_fragments_below = 0;
  /// Islands of fragments slower than sleep_speed for sleep_time are held still until
  /// something closes on them (sim::SleepSettings); sleep_speed 0 = never.
  double sleep_speed = kDefaultSleepSpeed;  ///< [m/s] ≥ 0
  double sleep_time = 0.25;                 ///< [s] > 0
  int threads = 0;               ///< 0 = all cores
  int max_splits_per_step = 64;  ///< fracture splits per step (per substep, see max_substep), ≥ 0 (0 = none)
};

struct SceneFeatures {
  bool fracture = false;
  bool collisions = true;
  bool self_collision = false;
  SceneCollisionMode collision_mode = SceneCollisionMode::Spheres;
  bool mass_weighting = true;
};

/// Where the images are seen from; without a [camera] the player frames the bodies and
/// follows them.
struct SceneCamera {
  Vec3 position = Vec3::Zero();  ///< [m]
  Vec3 target = Vec3::Zero();    ///< [m], not at position
  double fov_degrees = 30;       ///< vertical field of view, in (1, 170)
  std::optional<Vec3> up;        ///< the image's up (unit); none: the world's up
  int line = 0;                  ///< line of the [camera] header
};

struct Scene {
  std::filesystem::path file;  ///< the scene file as given to the reader
  SceneSolverSettings solver;
  SceneFeatures features;
  Vec3 gravity = Vec3(0, 0, -9.81);  ///< [m/s²]
  SceneGround ground;
  std::vector<SceneBox> boxes;
  std::vector<SceneSphere> spheres;
  std::vector<SceneObject> objects;  ///< at least one
  std::vector<SceneProjectile> projectiles;
  std::optional<SceneCamera> camera;
};

/// Where a fragment can break, contacts asking up to 0.5 m/s of it are answered rigidly
/// (docs/decisions/0073-rigid-answers-at-rest.md)...
inline constexpr double kRestingSpeedBreakable = 0.5;
/// ... and up to 1 m/s where nothing can (features.fracture off): what a faster limit
/// would lose is breaks, which such a scene has none of
/// (docs/decisions/0078-unbreakable-scenes-rest-rigidly-up-to-1-m-s.md).
inline constexpr double kRestingSpeedUnbreakable = 1.0;

/// The scene's solver.rigid_resting_speed, or its default for whether it can break.
[[nodiscard]] inline double rigid_resting_speed(const Scene& scene) {
  return scene.solver.rigid_resting_speed.value_or(scene.features.fracture ? kRestingSpeedBreakable
                                                                           : kRestingSpeedUnbreakable);
}

/// Reads and validates a scene file. Throws fissure::Error.
Scene read_scene(const std::filesystem::path& file);

/// Same, from text already in memory (tests). `file_for_messages` prefixes every error
/// and is the base that relative bundle paths are resolved against.
Scene parse_scene(std::string_view text, const std::filesystem::path& file_for_messages);

}  // namespace fissure::formats
