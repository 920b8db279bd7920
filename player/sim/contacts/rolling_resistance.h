#pragma once
/// Rolling resistance: each contact may exert a small couple against the relative spin
/// of its two sides, as the patch of a real contact does.
///
/// Why: the bake stands a tet's solid in with spheres, and a sphere can spin in place. A
/// contact's rows weigh the sphere's centre, which a spin does not move, so Coulomb
/// friction never sees it; the arcs (rigid_rotation.h) then keep the spin, as they
/// should for a free body. The one-tet fragments of a shattered pile spun in place at
/// 97-172 rad/s for seconds, their centres at rest, so the pile never came to rest
/// (docs/decisions/0035-rolling-resistance-and-sleeping-opt-in.md). A real chip is no sphere: its corners
/// would catch. Friction weighed where the spheres touch makes a spinning sphere roll
/// instead, and a rolling sphere rolls for ever; resistance to rolling is the standard
/// stand-in for the shape a sphere proxy leaves out (Box2D v3's rolling resistance,
/// Bullet's rolling and spinning friction).
///
/// Each contact with normal impulse p may exert an angular impulse of at most
/// μ_r · r · p (r: its sphere's radius, μ_r: the materials' coefficient), against the
/// difference of its two sides' rigid spins ω = I⁻¹ L (fragment by fragment, about each
/// one's centre of mass). The impulse is the part of the one that would equalise the two
/// spins, τ = s K⁻¹ (ω_a − ω_b) with K = I_a⁻¹ + I_b⁻¹ and s ≤ 1: an inelastic collision
/// in angular velocity, so the kinetic energy never rises (ΔE = −(s − s²/2) ω_relᵀ K⁻¹
/// ω_rel, also for a deformable fragment, whose rigid spin is the mass-weighted fit). It
/// is a couple, applied as a rigid change of spin about the centre of mass: linear
/// momentum and the centre of mass are kept exactly, and so is angular momentum between
/// two fragments (an obstacle or projectile, which has no spin here, takes its share as
/// the ground takes friction's). Contacts are taken in their given order, each once.

#include <span>
#include <vector>

#include "common/types.h"

namespace fissure::sim {

/// One side of a contact for rolling resistance: a fragment of a body, or something that
/// does not spin (an obstacle, a projectile: body = kInvalidIndex).
struct SpinSide {
  Index body = kInvalidIndex;
  Index fragment = 0;
};

struct RollingContact {
  SpinSide a, b;
  double max_angular_impulse = 0;  ///< μ_r · r · p [N m s]
};

/// What rolling resistance reads of one body.
struct SpinBody {
  const Matrix3Xd* positions = nullptr;   ///< 3×#N
  const Matrix3Xd* velocities = nullptr;  ///< 3×#N
  const Eigen::VectorXd* mass = nullptr;  ///< #N
  std::span<const std::uint8_t> pinned;   ///< #N, nonzero for a pinned node (its fragment does not spin here)
  std::span<const Index> node_fragment;   ///< #N, in [0, fragments)
  Index fragments = 0;
};

/// The velocity change per body (3×#N, zero where nothing changed) that applies each
/// contact's resistance in turn. A fragment with a pinned node, or whose inertia is
/// singular, is left alone and counts as not spinning.
std::vector<Matrix3Xd> resist_rolling(std::span<const SpinBody> bodies, std::span<const RollingContact> contacts);

}  // namespace fissure::sim
