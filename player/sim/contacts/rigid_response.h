#pragma once
/// Large fragments at rest, answered as rigid bodies (contact_response.cpp's internals,
/// not an API).
///
/// A large fragment lying on the ground costs the augmented Lagrangian 2–8 outer
/// iterations of conjugate gradients over all its nodes, step after step, while it does
/// nothing but rest: on the 12 sample variants those responses were 93 % of the
/// collision phase (issue 42). At rest its motion is rigid to within what the contacts
/// ask of it, so the answer can be too: the correction δ = V + Ω × rᵢ on its free nodes,
/// with V, Ω the six unknowns of a rigid body whose mass and inertia are the fragment's
/// lumped node masses. Such a fragment is a rigid group of the debris' sequential
/// impulses (sequential_impulses.h), beside the small fragments' exact blocks: a piece
/// on the ground with debris on and around it is answered in one problem, linear in its
/// contacts. The answer changes only the fragment's rigid kinetic energy (the rest of
/// its motion is orthogonal to it in the mass norm) and gains exactly the impulses,
/// linear and angular, that it received. The stiffness does not see it: the support's
/// load never strains the fragment, which is the rigid body's approximation.
///
/// At rest means: no projectile touches the fragment, no node of it is pinned or held,
/// each of its contacts (with obstacles or other fragments) asks for at most
/// `ContactSettings::rigid_resting_speed` of velocity change (or 2 |g| h where that is
/// more: holding it up asks |g| h), and its motion is rigid to within that speed (its
/// kinetic energy beyond the rigid part at most ½ m s²). Anything faster, an impact or
/// a hit, is answered with the fragment deformable, so it can still break; so is a
/// resting fragment whose contacts join it to a fragment that is not at rest, or to a hit
/// (contact_response.cpp's debris_contacts).

#include <span>
#include <vector>

#include "player/sim/contacts/contact.h"
#include "player/sim/contacts/contact_settings.h"
#include "player/sim/contacts/sequential_impulses.h"

namespace fissure::sim::contact_detail {

/// A large fragment at rest.
struct RestingFragment {
  Index body = 0;
  std::vector<NodeIndex> nodes;  ///< its free nodes
  bool small = false;            ///< rigid for its size (ContactSettings::rigid_fragments_below), not at rest
};

/// The large fragments (more than ContactSettings::dense_fragment_nodes free nodes) that
/// are at rest, as the header says (none if rigid_resting_speed is 0), and the fragments
/// of fewer tets than rigid_fragments_below that a contact touches, rigid whatever they
/// do. `reference_speed` is |g| h (ContactResponseSettings::reference_speed).
std::vector<RestingFragment> resting_fragments(std::span<const CollisionBody> bodies,
                                               std::span<const ContactConstraint> contacts,
                                               const ContactSettings& settings, double reference_speed);

/// The resting fragments of the bodies in `system`, as the sweeps' rigid groups over its
/// unknowns.
std::vector<RigidGroup> rigid_groups(std::span<const CollisionBody> bodies, std::span<const RestingFragment> resting,
                                     const JointSystem& system);

}  // namespace fissure::sim::contact_detail
