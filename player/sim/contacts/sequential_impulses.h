#pragma once
/// The contact response by sequential impulses (projected Gauss–Seidel on the contacts'
/// impulses, as Box2D and Jolt solve contacts), for a response whose every contact reads
/// only small fragments and projectiles: a shattered body's debris.
///
/// It solves the same problem as the augmented Lagrangian of contact_response.cpp,
///   minimise ½ δᵀ 𝒜 δ  subject to  n_k · G_k (v* + δ) ≥ target_k,  with Coulomb friction,
/// through its dual: δ = 𝒜⁻¹ Σ_k G_kᵀ F_k λ_k, with F_k the contact's frame (normal,
/// two tangents) and λ_k its impulse in that frame. After fracture, small fragments
/// share no tet, so 𝒜 is block diagonal over them and each block's inverse is exact
/// (BlockJacobi, the blocks the augmented Lagrangian uses as its preconditioner). Each
/// contact in turn takes the impulse that meets its target given the others' (its 3×3
/// Delassus block D_k = G_k 𝒜⁻¹ G_kᵀ in its frame), clamped to λ_n ≥ 0 and to the
/// friction cone |λ_t| ≤ μ λ_n, and moves δ by its change: a few dozen flops per
/// contact and sweep, against the augmented Lagrangian's conjugate-gradient products
/// over every row and block for each of its iterations (on the bunny at toughness 0,
/// about 150 a step). Friction is exact Coulomb here, not lagged damping.
///
/// The sweeps stop on the augmented Lagrangian's own rule (each contact within what it
/// may miss, and none pushing while it separates faster than asked), or at the cap.
/// Serial, in row order: the answer does not depend on the thread count. Momentum is
/// exact to rounding: each block answers exactly the impulses it received (its
/// stiffness has no net force), so the caller applies the answer without a momentum
/// shift (JointSystem::apply_exact).
///
/// A large fragment at rest can take part as a rigid group (rigid_response.h): its six
/// unknowns (V, Ω) stand for its nodes' δᵢ = V + Ω × rᵢ, a contact's side on it reads
/// s V + Ω × a (s = Σ wₑ, a = Σ wₑ rₑ over the side's entries), and an impulse p on
/// that side moves it by ΔV = s p / m, ΔΩ = I⁻¹ (a × p): the Delassus block of a rigid
/// body, s²/m − [a]× I⁻¹ [a]×, as Box2D and Jolt solve a body's contacts. A rigid δ
/// changes only the fragment's rigid kinetic energy and carries exactly its impulses.

#include <span>
#include <vector>

#include "player/sim/contacts/joint_system.h"

namespace fissure::sim::contact_detail {

/// A fragment the sweeps move rigidly: mass and inertia from its lumped node masses.
struct RigidGroup {
  std::vector<Eigen::Index> rows;  ///< each free node's first row in the system
  std::vector<Vec3> arms;          ///< each node's position less the centre of mass
  double mass = 0.0;
  Mat3 inverse_inertia = Mat3::Zero();  ///< about the centre of mass
  bool small = false;  ///< a small fragment, rigid whatever it does (not a resting large one)
};

struct SequentialImpulsesAnswer {
  Eigen::VectorXd delta;      ///< the correction, over the system's unknowns
  std::vector<Vec3> forces;   ///< each row's impulse as a vector [N s]
  int sweeps = 0;
  double largest_violation = 0.0;  ///< max_k (target_k − n · v_rel) after the answer [m/s]
  bool met = false;                ///< the stopping rule held before the cap
  bool acceptable = false;         ///< no contact misses its target by more than `acceptable` says
  int rigid_groups_moved = 0;      ///< resting large fragments' rigid groups a contact touched
};

/// Needs every row to read only sealed dense blocks (JointSystem::sealed_groups) or
/// rigid groups: each side's answer to an impulse is then its block's inverse exactly,
/// or its rigid body's. Updates each row's λ (its normal impulse),
/// starting from it (warm start). The sweeps stop once no contact misses its target by
/// more than its `tolerance`, nor pushes while separating faster than that (the
/// augmented Lagrangian's rule, contact_response.cpp), or at `max_sweeps`; then the
/// answer is `acceptable` if no contact misses its target by more than that.
SequentialImpulsesAnswer solve_by_sequential_impulses(JointSystem& system, std::span<const RigidGroup> rigid,
                                                      std::span<const double> tolerance,
                                                      std::span<const double> acceptable, int max_sweeps);

}  // namespace fissure::sim::contact_detail
