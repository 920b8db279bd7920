#pragma once
/// Contacts between embedded collision points (the bake's spheres, or every render
/// vertex in the reference mode), projectiles and static obstacles (thesis IV.H).
///
/// Detection runs once per step, after the implicit solve, on the motion from the
/// start-of-step positions to the solver's end positions; every test is swept, so
/// nothing fast passes through anything (see ContactCounts).
///
/// Each contact asks for a normal relative velocity (speculative contacts, as in Box2D):
/// it may close its start-of-step gap during the step but not cross it, vₙ ≥ −gap / h,
/// with restitution above a resting speed and Coulomb friction. The response
/// (contact_response.h) meets those targets inside the implicit step: the velocity
/// correction solves the bodies' own implicit systems with the contact impulses, so a
/// body answers a contact as a whole and elastically.
///
/// Deviations from the thesis (IV.H), which offsets every node of a colliding tet by the
/// largest offset of its spheres:
///  - Offsetting positions without the matching velocities stores spurious elastic
///    energy: on the bunny drop that was 7 J of strain energy out of 1 J of fall.
///  - Taking the largest offset per node does not conserve momentum between two moving
///    bodies; impulses do.
///  - Moving only the colliding tet's nodes (by an offset, or by an impulse applied after
///    the solve, as earlier versions did) stores the hit as strain of that tet, which the
///    next step releases: the 0.5 kg ball at 12 m/s (36 J) left the bunny with 305 J.
/// Contacts are handled in a fixed order, so results do not depend on the thread count.

#include <compare>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include "player/sim/contacts/broad_phase.h"
#include "player/sim/contacts/contact.h"
#include "player/sim/contacts/contact_settings.h"
#include "player/sim/contacts/sleeping.h"
#include "player/sim/contacts/split_overlaps.h"
#include "player/sim/environment.h"
#include "player/sim/implicit_integrator.h"

namespace fissure::sim {


struct CollisionSettings {
  double dt = 1.0 / 240.0;
  Vec3 gravity = Vec3(0, 0, -9.81);  ///< sets the resting speed (no restitution below 2 |g| h)
  bool self_collision = false;       ///< between fragments and between bodies
  ContactSettings contacts;          ///< the targets' and the response's tuning values
  bool sparse_blocks_from_start = false;  ///< ContactResponseSettings::sparse_blocks_from_start
  ContactImpulses* impulses = nullptr;  ///< in: last step's impulses (warm start); out: this step's
};

/// No tunnelling: every test is swept over the step (sphere–sphere by the exact time
/// of impact of the relative motion, sphere–box as a segment against the box grown by
/// the radius, sphere–ground against the half space), so no sub-steps are needed.
struct ContactCounts {
  std::size_t contacts = 0;
  std::size_t swept = 0;         ///< contacts whose end states do not overlap: only the swept test caught them
  std::size_t pairs_tested = 0;  ///< narrow-phase point pairs of the self-collision broad phase
  std::size_t response_iterations = 0;  ///< conjugate-gradient iterations of the contact response
  std::size_t response_sweeps = 0;      ///< its sequential-impulse sweeps (sequential_impulses.h)
  std::size_t rigid_answers = 0;  ///< large fragments at rest answered as rigid bodies (rigid_response.h)
  std::size_t responses = 0;     ///< contact responses solved (World answers a substep twice to limit restitution)
  std::size_t restituting = 0;   ///< contacts whose target restitution raised (impacts above the resting speed)
  bool ran_long = false;         ///< the response's ContactResponseReport::ran_long
  bool swept_to_cap = false;     ///< the response's ContactResponseReport::swept_to_cap

  /// Adds what another answer of the same contacts cost (its iterations, sweeps, rigid
  /// answers and responses), not its contacts.
  void add_response(const ContactCounts& answer) {
    response_iterations += answer.response_iterations;
    response_sweeps += answer.response_sweeps;
    rigid_answers += answer.rigid_answers;
    responses += answer.responses;
  }
};

/// The contacts of one step, found once (detection and targets), then answered by the
/// response with any share of their restitution: World::collide answers twice when the
/// full restitution would add energy, without finding the contacts again.
class StepContacts {
 public:
  /// Finds every contact of the step; the arguments must outlive this.
  StepContacts(std::span<CollisionBody> bodies, const Environment& environment, std::span<Projectile> projectiles,
               std::span<const Vec3> projectile_start, const CollisionSettings& settings);
  ~StepContacts();
  StepContacts(const StepContacts&) = delete;
  StepContacts& operator=(const StepContacts&) = delete;
  /// Corrects the bodies and projectiles so every contact holds, with `restitution_share`
  /// ∈ [0, 1] of each contact's restitution (0: inelastic). Answers the motion the
  /// bodies have: to answer again, first restore the motion they had before.
  /// `iterations`: the augmented-Lagrangian iterations at most (0: the settings').
  ContactCounts respond(double restitution_share, int iterations = 0);
  /// Every contact's sides, fragment by fragment, and how fast they closed before the
  /// response (sleeping.h).
  [[nodiscard]] std::vector<Touch> touches() const;
  /// Contacts whose restitution asks for more than the inelastic target.
  [[nodiscard]] std::size_t restituting() const { return m_counts.restituting; }

 private:
  std::span<CollisionBody> m_bodies;
  std::span<Projectile> m_projectiles;
  std::span<const Vec3> m_projectile_start;
  CollisionSettings m_settings;
  ContactCounts m_counts;
  std::vector<ContactConstraint> m_constraints;
  std::vector<ContactKey> m_keys;
  std::vector<double> m_approach, m_inelastic_target, m_elastic_target;  ///< per contact [m/s]
  bool m_answered = false;  ///< respond() ran: the constraints' impulses are its answer
};

/// Finds and resolves every contact of the step, with full restitution. The bodies have
/// been solved and the launched projectiles moved (World) from `projectile_start` (one
/// per projectile) to their positions; the response corrects both.
ContactCounts resolve_collisions(std::span<CollisionBody> bodies, const Environment& environment,
                                 std::span<Projectile> projectiles, std::span<const Vec3> projectile_start,
                                 const CollisionSettings& settings);

/// Rolling resistance (rolling_resistance.h) with the last step's contacts and their
/// normal impulses (`impulses`), on the bodies' velocities after their solve: each
/// contact between fragments, or of a fragment with an obstacle, takes at most μ_r r p
/// out of its sides' relative spin (projectiles' contacts do not). Returns how many
/// contacts resisted.
std::size_t resist_rolling(std::span<CollisionBody> bodies, const Environment& environment,
                           const ContactImpulses& impulses);

/// Earliest s ∈ [0, 1] at which two points moving linearly (a0 → a1, b0 → b1) come
/// within `distance`; 0 when they start within it, nullopt when they never do.
std::optional<double> time_of_impact(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1,
                                     double distance);

/// Which obstacle a point is deepest in.
struct ObstacleHit {
  enum class Kind : std::uint8_t { None, Ground, Box, Ball, Projectile } kind = Kind::None;
  Index index = 0;    ///< which box, ball or projectile
  double depth = 0;   ///< [m], 0 when clear
};

/// The obstacle or launched projectile a ball of `radius` at `point` is deepest inside,
/// and how deep (depth 0, kind None when clear).
ObstacleHit deepest_obstacle(const Vec3& point, double radius, const Environment& environment,
                             std::span<const Projectile> projectiles);

/// How deep a ball of `radius` at `point` is inside the environment's obstacles or the
/// launched projectiles (0 when clear) [m].
inline double penetration(const Vec3& point, double radius, const Environment& environment,
                          std::span<const Projectile> projectiles) {
  return deepest_obstacle(point, radius, environment, projectiles).depth;
}

}  // namespace fissure::sim
