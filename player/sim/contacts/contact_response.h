#pragma once
/// Contact response inside the implicit step.
///
/// After the implicit solve, each body's velocities v* solve A Δv = b. Contacts found on
/// that motion ask for normal relative velocities n · (v_a − v_b) ≥ target. The
/// response finds the velocity correction δ that a backward-Euler step with contact
/// impulses would have made:
///   minimise ½ δᵀ 𝒜 δ  subject to  c_k · (v* + δ) ≥ target_k,
/// with 𝒜 = diag(each body's system A, each projectile's mass). Its solution is
/// 𝒜 δ = Σ λ_k c_k with λ_k ≥ 0: a body answers an impulse as the implicit step would,
/// as a whole and elastically, not by moving one tet (the response that stored ×9 the
/// energy of the ball hitting the bunny as strain,
/// docs/decisions/0020-contacts-inside-the-implicit-step.md). Because the
/// correction minimises a positive-definite form subject to the targets, an inelastic
/// contact (target ≤ 0) does negative work and never adds energy; only restitution and
/// the capped push-out of old overlaps ask for a separating velocity.
///
/// Solved by an augmented Lagrangian (Nocedal & Wright 17.4): each outer iteration
/// solves (𝒜 + Σ_active κ_k c_k c_kᵀ + friction) δ = Σ_active (λ_k + κ_k r_k) c_k by
/// conjugate gradients, moves δ towards that answer as far as the augmented Lagrangian
/// decreases (an exact line search: the active set changes along the way), then updates
/// λ_k ← max(0, λ_k + κ_k (r_k − c_k · δ)). κ_k is about the point's effective mass in
/// the system, so the preconditioned system stays well conditioned while λ carries the
/// exact force. λ starts from the last step's impulse of the same contact (resting
/// contacts carry nearly the same impulse every step).
///
/// The preconditioner is block Jacobi: each small fragment's (and projectile's) dense
/// block of that operator, its contacts' terms included, solved exactly; each larger
/// fragment keeps its body's own preconditioner, which cannot see the contacts, until a
/// solve runs long (ContactSettings::sparse_blocks_after): then each larger fragment
/// that a contact touches gets a sparse block of its own likewise (sparse_blocks.h), and
/// no body's own preconditioner is used. A shattered body is hundreds of small
/// fragments in a pile, coupled mostly through their contacts: there the blocks cut the
/// response's CG iterations severalfold (docs/decisions/0024-block-jacobi-with-contacts.md).
///
/// Friction is Coulomb, lagged (as in IPC, Li et al. 2020): a tangential damping
/// η_k = μ λ_k / max(|v_t|, ε) from the previous outer iteration, so its force is
/// μ λ_k while sliding and holds the point while sticking; damping never adds energy.
///
/// Momentum: the conjugate-gradient residual is a small unbalanced force, so at the end
/// each body free of pins is shifted rigidly (no elastic work) to gain exactly the
/// impulses it received, and each projectile gets exactly its own: the momentum the
/// contacts exchange sums to zero to rounding. That shift is part of the answer, so the
/// iterations stop only once the contacts hold with it (ContactResponseSettings).

#include <span>

#include "player/sim/contacts/contact.h"
#include "player/sim/contacts/contact_settings.h"

namespace fissure::sim {


/// One response's settings: the contacts' tuning values and what the step adds to them.
struct ContactResponseSettings {
  ContactSettings contacts;
  double dt = 1.0 / 240.0;
  /// A speed every contact may miss its target by `relative_violation` of [m/s]: the
  /// caller passes about what one step of gravity adds, |g| h, what resting contacts ask
  /// for (ContactSettings::relative_violation).
  double reference_speed = 0.0;
  /// Make the sparse blocks before the first solve: the caller's memory that recent
  /// responses ran long (ContactSettings::sparse_block_memory).
  bool sparse_blocks_from_start = false;
};

struct ContactResponseReport {
  int outer_iterations = 0;
  int cg_iterations = 0;           ///< summed over outer iterations
  double largest_violation = 0.0;  ///< max_k (target_k − n · v_rel) after the response [m/s]
  /// A solve took more than ContactSettings::sparse_blocks_after iterations.
  bool ran_long = false;
  int sweeps = 0;                  ///< sequential-impulse sweeps, where they answered (then no CG)
  /// The sequential impulses swept to their cap (ContactSettings::sequential_impulse_sweeps).
  bool swept_to_cap = false;
  int rigid_answers = 0;           ///< large fragments at rest answered as rigid bodies (rigid_response.h)
};

/// Corrects the velocities of `bodies` and `projectiles` so the contacts hold, and moves
/// the bodies' nodes by h δ with them (projectile positions are the caller's). Needs each
/// body's last solve() (ImplicitIntegrator::multiply_system).
ContactResponseReport respond_to_contacts(std::span<CollisionBody> bodies, std::span<Projectile> projectiles,
                                          std::span<ContactConstraint> contacts, const ContactResponseSettings& settings);

}  // namespace fissure::sim
