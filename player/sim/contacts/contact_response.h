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
/// solve runs long: then each larger fragment that a contact touches gets a sparse block
/// of its own likewise (sparse_blocks.h, `sparse_blocks_after`), and no body's own
/// preconditioner is used. A shattered body is hundreds of small fragments in a pile,
/// coupled mostly through their contacts: there the blocks cut the response's CG
/// iterations severalfold (docs/decisions/0024-block-jacobi-with-contacts.md).
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

namespace fissure::sim {


struct ContactResponseSettings {
  double dt = 1.0 / 240.0;
  int iterations = 8;            ///< augmented-Lagrangian iterations at most
  /// The iterations stop once every contact misses its target by at most this share of
  /// its own required velocity change, or of `reference_speed` if that is larger. Per
  /// contact, not of the largest: a hit asking 12 m/s of one contact must not excuse
  /// millimetres of sinking at the others. What a contact still misses becomes overlap,
  /// which the push-out target of the next steps removes.
  double relative_violation = 0.1;
  /// A speed every contact may miss its target by that share of [m/s]: the caller
  /// passes about what one step of gravity adds, |g| h, what resting contacts ask for.
  double reference_speed = 0.0;
  /// And never by more than this share of its reach (ContactConstraint::reach) per step,
  /// reach_share × reach / h: what a contact misses becomes overlap, and a share of a
  /// speed is a length that grows with h² (|g| h² / 10: 0.25 m of a resting bunny's
  /// spheres sunk in one step of 0.5 s, 10 m of a bar under 1e4 m/s² in one of 0.1 s).
  /// At the scene's steps it rarely binds (a 3 mm sphere at 1/240 s: 0.7 m/s).
  double reach_share = 1.0;
  /// Conjugate gradients' relative residual. Loose on purpose: the outer iterations
  /// correct what an inner solve leaves, and the momentum each body gains is made exact
  /// at the end anyway. On the bunny scene 1e-6 took 2.2× the time of 1e-3 for the same
  /// energy and penetration.
  double tolerance = 1e-3;
  /// Each outer iteration's solve also takes its residual to at most this share of its
  /// start (conjugate_gradient's residual_reduction). Warm-started from the last δ, the
  /// start is often within `tolerance` of the whole right-hand side already, which heavy
  /// rows dominate: the solve then did nothing, the outer iterations only moved λ, and a
  /// light projectile's rows (0.1 kg against 167 kg fragments) were never solved.
  double inner_reduction = 0.1;
  int max_cg_iterations = 500;   ///< per outer iteration
  /// An outer iteration whose solve took more conjugate-gradient iterations than this
  /// makes the rest of the response precondition each large fragment (over 64 free
  /// nodes) that a contact touches with a sparse block of its own, its contacts' terms
  /// included, in place of its body's own preconditioner, which cannot see them. The
  /// blocks cost sparse factorizations (per outer iteration; per response for a block
  /// over SparseBlocks::kKeptFactorNodes nodes), which pay only where the solves
  /// without them are long: on the bunny at toughness 0.2, while a fragment of
  /// hundreds of nodes lay among a hundred small ones, the response took 746
  /// conjugate-gradient iterations per step without them and 263 with them; ordinary
  /// solves take 2-20 and never make them.
  int sparse_blocks_after = 40;
  /// Make the sparse blocks before the first solve: the caller's memory that recent
  /// responses ran long. In a pile, every response's first solve ran long again on its
  /// body's own preconditioner before the blocks took over (most of the response's
  /// conjugate-gradient iterations, and each of them a solve over the whole body).
  bool sparse_blocks_from_start = false;
  /// The contacts of islands that read only small fragments and projectiles (a
  /// shattered body's debris) are answered by sequential impulses, at most this many
  /// sweeps (sequential_impulses.h); the rest, and all of them at 0, by the augmented
  /// Lagrangian. On the bunny at toughness 0, 16 sweeps made the step 0.57× as long
  /// with the same sphere penetration; 8 left more islands to the fallback below.
  int sequential_impulse_sweeps = 16;
  /// The sweeps' tolerance per contact is the augmented Lagrangian's, but never more
  /// than this share of its reach per step; at the cap their answer is kept if no
  /// contact falls short by more than that, else the augmented Lagrangian answers the
  /// island from the last step's impulses. On the bunny at toughness 0 at 16 sweeps, 0.1
  /// left so many islands to the fallback that the step took 37.5 ms against 29.4 at
  /// 0.25 (51.3 with no sweeps), at the same penetration
  /// (docs/decisions/0072-sequential-impulses-for-debris.md).
  double sequential_impulse_reach_share = 0.25;
};

struct ContactResponseReport {
  int outer_iterations = 0;
  int cg_iterations = 0;           ///< summed over outer iterations
  double largest_violation = 0.0;  ///< max_k (target_k − n · v_rel) after the response [m/s]
  bool ran_long = false;           ///< a solve took more than sparse_blocks_after iterations
  int sweeps = 0;                  ///< sequential-impulse sweeps, where they answered (then no CG)
};

/// Corrects the velocities of `bodies` and `projectiles` so the contacts hold, and moves
/// the bodies' nodes by h δ with them (projectile positions are the caller's). Needs each
/// body's last solve() (ImplicitIntegrator::multiply_system).
ContactResponseReport respond_to_contacts(std::span<CollisionBody> bodies, std::span<Projectile> projectiles,
                                          std::span<ContactConstraint> contacts, const ContactResponseSettings& settings);

}  // namespace fissure::sim
