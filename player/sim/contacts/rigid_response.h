#pragma once
/// The contact response of a large fragment at rest on static obstacles, answered as a
/// rigid body (contact_response.cpp's internals, not an API).
///
/// A large fragment lying on the ground costs the augmented Lagrangian 2–8 outer
/// iterations of conjugate gradients over all its nodes, step after step, while it does
/// nothing but rest: on the 12 sample variants those responses were 93 % of the
/// collision phase (issue 42). At rest its motion is rigid to within what the contacts
/// ask of it, so the answer can be too: the correction δ = V + Ω × rᵢ on its free nodes,
/// with V, Ω the six unknowns of a rigid body whose mass and inertia are the fragment's
/// lumped node masses, found by sequential impulses on the contacts (exact Coulomb
/// friction, warm-started from the last step's normal impulses), as Box2D and Jolt
/// answer a rigid body's contacts. It changes only the fragment's rigid kinetic energy
/// (the rest of its motion is orthogonal to it in the mass norm) and gains exactly the
/// impulses, linear and angular, that it received. The stiffness does not see it: the
/// support's load never strains the fragment, which is the rigid body's approximation.
///
/// At rest means: every contact on the fragment is with a static obstacle (no other
/// fragment, no projectile), no node of it is pinned or held, each contact asks for at
/// most `ContactSettings::rigid_resting_speed` of velocity change (or 2 |g| h where that is
/// more: holding it up asks |g| h), and its motion is rigid to within that
/// speed (its kinetic energy beyond the rigid part at most ½ m s²).
/// Anything faster, an impact or a hit, is answered by the augmented Lagrangian with
/// the fragment deformable, so it can still break.

#include <span>
#include <vector>

#include "player/sim/contacts/contact.h"
#include "player/sim/contacts/contact_settings.h"

namespace fissure::sim::contact_detail {

/// A large fragment at rest and the contacts on it.
struct RestingFragment {
  Index body = 0;
  std::vector<NodeIndex> nodes;          ///< its free nodes
  std::vector<std::size_t> contacts;     ///< indices into the response's contacts
};

/// The large fragments (more than ContactSettings::dense_fragment_nodes free nodes) that
/// are at rest, as the header says; none if rigid_resting_speed is 0. `reference_speed`
/// is |g| h (ContactResponseSettings::reference_speed).
std::vector<RestingFragment> resting_fragments(std::span<const CollisionBody> bodies,
                                               std::span<const ContactConstraint> contacts,
                                               const ContactSettings& settings, double reference_speed);

/// What answering one resting fragment did.
struct RigidAnswer {
  bool acceptable = false;  ///< no contact short of its target by more than the sweeps accept
  int sweeps = 0;
};

/// Answers the fragment's contacts with it moving rigidly: if acceptable, corrects its
/// nodes' velocities (and positions by h δ) and writes each contact's normal impulse;
/// otherwise changes nothing. `reference_speed` as ContactResponseSettings'.
RigidAnswer answer_as_rigid(const RestingFragment& fragment, CollisionBody& body,
                            std::span<ContactConstraint> contacts, const ContactSettings& settings, double dt,
                            double reference_speed);

}  // namespace fissure::sim::contact_detail
