#pragma once
/// A scene in motion: deformable bodies, projectiles and static obstacles, stepped
/// together. Each step: evaluate every body's tets → fracture → implicit solve →
/// collisions. A feature that is off costs nothing: without fracture no stresses are
/// kept, without collisions no points are swept.

#include <memory>
#include <string>
#include <vector>

#include "player/sim/collision.h"
#include "player/sim/fracture.h"
#include "player/sim/implicit_integrator.h"

namespace fissure::sim {

enum class CollisionPoints { Spheres, RenderVertices };

/// Everything needed to build one body; the app fills it from a bundle and a scene.
struct BodyDescription {
  std::string name;
  Matrix3Xd rest;          ///< 3×#N cage nodes in world space at rest [m]
  Matrix4Xu tets;          ///< 4×#T, positively oriented
  Material material;
  double toughness = std::numeric_limits<double>::infinity();  ///< [N]
  ContactMaterial contact;
  std::optional<MassDistribution> mass;  ///< solid fraction and centre of mass per tet
  EmbeddedPoints spheres;        ///< the bake's collision spheres (empty: see World)
  EmbeddedPoints vertices;       ///< every render vertex (radius 0), for the exact mode and penetration
  std::vector<NodeIndex> pinned;
  Matrix3Xd velocity;            ///< 3×#N initial node velocities (empty: at rest)
};

struct WorldSettings {
  StepSettings step;
  double min_dt = 0;  ///< > 0: a step whose solve fails is retried as two halves, down to this
  bool fracture = false;
  int max_splits_per_step = 64;
  bool collisions = true;
  bool self_collision = false;
  CollisionPoints collision_points = CollisionPoints::Spheres;
  int contact_iterations = 8;
};

/// What one step did, for reports.
struct StepReport {
  double forces = 0, assembly = 0, solve = 0, fracture = 0, collisions = 0;  ///< [s] wall clock
  int substeps = 1;                 ///< > 1 when adaptive stepping halved dt
  int solver_iterations = 0;        ///< summed over bodies and substeps
  int factorizations = 0;           ///< numeric Cholesky factorizations, summed likewise
  bool unconverged = false;         ///< a CG solve hit the iteration cap
  std::vector<std::pair<Index, NodeSplit>> splits;      ///< (body, split)
  std::vector<std::pair<Index, TetFace>> exposed;       ///< (body, face newly on the boundary)
  ContactCounts contacts;
};

struct Body {
  std::string name;
  std::unique_ptr<ImplicitIntegrator> solver;  ///< pinned in memory (see ImplicitIntegrator)
  FractureTopology topology;
  FractureSettings fracture;
  ContactMaterial contact;
  EmbeddedPoints spheres;
  EmbeddedPoints vertices;
  [[nodiscard]] const EmbeddedPoints& collision_points(CollisionPoints mode) const {
    return mode == CollisionPoints::Spheres ? spheres : vertices;
  }
};

class World {
 public:
  /// Throws fissure::Error on invalid input. A body without baked spheres gets one
  /// sphere per tet, at its centroid and inside the tet, so collisions still work.
  World(std::vector<BodyDescription> bodies, Environment environment, std::vector<Projectile> projectiles,
        WorldSettings settings);

  /// Advances by settings.step.dt. Throws fissure::Error when the solve fails even at
  /// min_dt (or at dt with fixed steps), naming the time, body and reason.
  StepReport step();

  [[nodiscard]] double time() const { return m_time; }
  [[nodiscard]] const std::vector<Body>& bodies() const { return m_bodies; }
  [[nodiscard]] const std::vector<Projectile>& projectiles() const { return m_projectiles; }
  [[nodiscard]] const Environment& environment() const { return m_environment; }
  [[nodiscard]] const WorldSettings& settings() const { return m_settings; }

  [[nodiscard]] double kinetic_energy() const;
  [[nodiscard]] double elastic_energy() const;
  [[nodiscard]] double potential_energy() const;  ///< gravity, relative to the origin
  [[nodiscard]] Vec3 linear_momentum() const;
  [[nodiscard]] Vec3 angular_momentum() const;    ///< about the origin
  [[nodiscard]] Index fragment_count() const;     ///< summed over bodies
  /// Deepest penetration [m] of any body's collision spheres, or of any render vertex,
  /// into obstacles and projectiles: the second is what a viewer sees (thesis VI.B.1).
  [[nodiscard]] double sphere_penetration() const;
  [[nodiscard]] double vertex_penetration() const;

 private:
  void advance(double dt, StepReport& report, int depth);

  std::vector<Body> m_bodies;
  Environment m_environment;
  std::vector<Projectile> m_projectiles;
  WorldSettings m_settings;
  double m_time = 0;
  std::vector<Matrix3Xd> m_start_positions;
  ContactImpulses m_contact_impulses;  ///< the last step's, to warm-start the next
};

}  // namespace fissure::sim
