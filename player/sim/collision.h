#pragma once
/// Contacts between embedded collision points (the bake's spheres, or every render
/// vertex in the reference mode), projectiles and static obstacles (thesis IV.H).
///
/// Detection runs once per step, after the implicit solve, on the motion from the
/// start-of-step positions to the solver's end positions; every test is swept, so
/// nothing fast passes through anything (see ContactCounts).
///
/// Response is speculative contacts with sequential impulses (Catto, "Contact
/// Manifolds", GDC 2007; speculative margin as in Box2D): each contact may close its
/// start-of-step gap during the step but not cross it, vₙ ≥ −gap / h, plus restitution
/// above a resting speed and Coulomb friction, with accumulated and clamped impulses.
/// Positions are then re-integrated from the start of the step with the corrected
/// velocities, so positions and velocities stay consistent.
///
/// Deviations from the thesis (IV.H), which offsets every node of a colliding tet by the
/// largest offset of its spheres:
///  - Offsetting positions without the matching velocities stores spurious elastic
///    energy: on the bunny drop that was 7 J of strain energy out of 1 J of fall.
///  - Taking the largest offset per node does not conserve momentum between two moving
///    bodies; impulses do (the tet's nodes gain exactly the impulse).
/// Kept from the thesis: a point embedded in a tet acts by moving the tet's free nodes
/// rigidly (each by J / M, M their summed mass), so a contact never deforms the tet it
/// acts on. (Spreading by barycentric weight over node mass instead throws light nodes
/// — those in nearly empty tets — far.) Contacts are handled in a fixed order, so
/// results do not depend on the thread count.

#include <optional>
#include <span>
#include <vector>

#include "player/sim/implicit_integrator.h"

namespace fissure::sim {

struct ContactMaterial {
  double restitution = 0.2;  ///< in [0, 1]; pairs use the larger
  double friction = 0.5;     ///< Coulomb μ ≥ 0; pairs use √(μa μb)
};

struct Plane {
  Vec3 normal = Vec3::UnitZ();  ///< unit, pointing out of the solid half space
  double offset = 0;            ///< the plane is normal · x = offset
  ContactMaterial material;
};
struct Box {
  Vec3 min, max;
  ContactMaterial material;
};
struct Ball {
  Vec3 center;
  double radius = 0;
  ContactMaterial material;
};
struct Environment {
  std::optional<Plane> ground;
  std::vector<Box> boxes;
  std::vector<Ball> balls;
};

/// A rigid ball thrown into the scene (the thesis's ball that hits the armadillo).
struct Projectile {
  Vec3 position = Vec3::Zero();  ///< at launch, then current [m]
  Vec3 velocity = Vec3::Zero();  ///< at launch, then current [m/s]
  double radius = 0.1;
  double mass = 1.0;
  double launch_time = 0;        ///< [s]; absent from the scene before this
  ContactMaterial material;
  bool launched = false;
};

/// Points bound to a body's tets by barycentric coordinates.
struct EmbeddedPoints {
  std::vector<TetIndex> tet;
  std::vector<Vec4> barycentric;
  std::vector<double> radius;  ///< 0 for render vertices
  [[nodiscard]] std::size_t size() const { return tet.size(); }
};

/// What collisions see of one deformable body.
struct CollisionBody {
  ImplicitIntegrator* body = nullptr;
  const EmbeddedPoints* points = nullptr;
  const Matrix3Xd* start_positions = nullptr;  ///< node positions at the start of the step
  const std::vector<Index>* tet_fragment = nullptr;  ///< fragment of each tet (self-collision)
  ContactMaterial material;
};

struct CollisionSettings {
  double dt = 1.0 / 240.0;
  Vec3 gravity = Vec3(0, 0, -9.81);  ///< moves the projectiles
  bool self_collision = false;       ///< between fragments and between bodies
  int iterations = 8;                ///< sequential-impulse sweeps over all contacts
};

/// No tunnelling: every test is swept over the step (sphere–sphere by the exact time
/// of impact of the relative motion, sphere–box as a segment against the box grown by
/// the radius, sphere–ground against the half space), so no sub-steps are needed.
struct ContactCounts {
  std::size_t contacts = 0;
  std::size_t swept = 0;         ///< contacts whose end states do not overlap: only the swept test caught them
  std::size_t pairs_tested = 0;  ///< narrow-phase point pairs of the self-collision broad phase
};

/// Launches due projectiles, moves them over the step, then finds and resolves every
/// contact. `time` is the simulation time at the start of the step.
ContactCounts resolve_collisions(std::span<CollisionBody> bodies, const Environment& environment,
                                 std::span<Projectile> projectiles, double time, const CollisionSettings& settings);

/// Earliest s ∈ [0, 1] at which two points moving linearly (a0 → a1, b0 → b1) come
/// within `distance`; 0 when they start within it, nullopt when they never do.
std::optional<double> time_of_impact(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1,
                                     double distance);

/// How deep a ball of `radius` at `point` is inside the environment's obstacles or the
/// launched projectiles (0 when clear) [m].
double penetration(const Vec3& point, double radius, const Environment& environment,
                   std::span<const Projectile> projectiles);

/// World position of embedded point k.
inline Vec3 embedded_position(const Matrix3Xd& x, const Matrix4Xu& tets, const EmbeddedPoints& points, std::size_t k) {
  const TetIndex t = points.tet[k];
  const Vec4& b = points.barycentric[k];
  return b[0] * x.col(tets(0, t)) + b[1] * x.col(tets(1, t)) + b[2] * x.col(tets(2, t)) + b[3] * x.col(tets(3, t));
}

}  // namespace fissure::sim
