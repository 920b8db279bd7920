#pragma once
/// Every tuning value of the contacts, in one place (as Jolt's PhysicsSettings gathers
/// its solver's): what each one trades, and the figure that chose its default. A scene
/// sets some of them in its [solver] table (formats/scene.h: contact_iterations,
/// contact_sweeps); the rest stay at these defaults outside studies and tests. The
/// records in docs/decisions/ hold the measurements behind each.

#include <algorithm>
#include <cmath>

#include "common/types.h"

namespace fissure::sim {

struct ContactSettings {
  // --- Targets (collision.cpp, contact_targets) ---------------------------------------
  /// An overlap left from earlier steps is pushed out at this share of its depth per
  /// step...
  double push_out_share = 0.2;
  /// ... but no faster than this [m/s]: the push-out is a real velocity that stays after
  /// the overlap is gone, so uncapped it would grow as 1/h (a 6 mm overlap at h = 1e-5 s
  /// threw fragments apart at 120 m/s). Box2D caps it the same way
  /// (contactPushMaxVelocity).
  double max_push_out_speed = 1.0;

  // --- The augmented Lagrangian (contact_response.cpp) --------------------------------
  /// Outer iterations at most (docs/decisions/0034-contact-iterations-default-8.md).
  int iterations = 8;
  /// The iterations stop once every contact misses its target by at most this share of
  /// its own required velocity change, or of the reference speed (about what one step of
  /// gravity adds, |g| h: what resting contacts ask for) if that is larger. Per contact,
  /// not of the largest: a hit asking 12 m/s of one contact must not excuse millimetres
  /// of sinking at the others. What a contact still misses becomes overlap, which the
  /// push-out of the next steps removes (docs/decisions/0021-response-stopping-rule.md).
  double relative_violation = 0.1;
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
  int max_cg_iterations = 500;  ///< per outer iteration
  /// κ_k = penalty_ratio / Σᵢ bᵢ² / (nᵀ Aᵢᵢ n), the point's inverse mass as the system's
  /// diagonal sees it. Not the lumped mass: where h²K dominates (light surface nodes,
  /// stiff materials) a point answers an impulse 50× less than its mass says, and κ from
  /// the mass took 8 iterations to meet half of a single contact's target. For one node
  /// (A⁻¹)ᵢᵢ ≥ 1 / Aᵢᵢ, so each iteration leaves at most 1 / (1 + penalty_ratio) of its
  /// shortfall (below the cap that follows). Larger ratios do fewer outer iterations but
  /// make the inner solves harder, which their preconditioners (the bodies' own) do not
  /// see. Measured on the bunny scene (480 steps, inner tolerance 1e-3): ratio 1 took 26
  /// CG iterations per response and 2 took 36 (4 and 16 took 43 and 57 before a fix to
  /// the stopping rule); penetration did not improve above 1. A preconditioner that sees
  /// the contacts did not pay for itself either
  /// (docs/decisions/0020-contacts-inside-the-implicit-step.md).
  double penalty_ratio = 1.0;
  /// ... but the diagonal counts for at most this many times the lumped mass: κ far above
  /// the mass makes any residual the inner solve leaves in a body's rigid motion (where A
  /// is only M) a velocity error Aᵢᵢ / mᵢ times larger. Uncapped, E = 1e11 at dt = 0.1
  /// (Aᵢᵢ / mᵢ ~ 1e8) ran away to 1e35 J in the stability grid. With the cap at 1, 4 or 16
  /// the grid holds; the bunny scene's render-vertex penetration is 2.4, 1.5 and 0.8 mm.
  double max_stiffness_share = 16.0;
  /// A contact that pushed in an outer iteration and still falls short of its target by
  /// more than this share of what it fell short by after the last one has stalled. Where
  /// h²K dominates a point's diagonal, max_stiffness_share holds its κ far below what the
  /// point answers with, and each iteration moved it by 1-3 % of its shortfall: on one
  /// breaking sample variant 242 of the large piece's 293 responses ran to the iteration
  /// cap, one or two such contacts still short when they stopped. A stalled
  /// contact's κ grows by stalled_penalty_growth, up to max_penalty_growth times where it
  /// started (the classic augmented Lagrangian's penalty update, per contact), so only
  /// the rows that need it make the inner solves harder. A projectile's contacts keep
  /// theirs: its velocity comes from its forces, not from δ (JointSystem::apply), and
  /// growing them let a 1,000 kg projectile under 1e4 m/s² at dt = 0.1 s sink 118 m into
  /// a light bar. Over the 12 sample variants, growth 4 up to 64: response CG × 0.70,
  /// step × 0.86; up to 16, or 8 up to 256, cost more
  /// (docs/decisions/0083-stalled-contacts-stiffen.md). Growth 1: never.
  double stalled_shortfall_share = 0.5;
  double stalled_penalty_growth = 4.0;
  double max_penalty_growth = 64.0;
  /// Sliding slower than this [m/s] counts as sticking: the lagged friction's damping is
  /// capped at μ λ / stick_speed, ...
  double stick_speed = 1e-3;
  /// ... and in any case at this many times κ, for conditioning. Over six toughness 0.2
  /// variants (`TOUGHNESS=0.2 SPEEDS="10 12 14" scripts/sample-variants.sh`), 1 and 16
  /// took the step ×1.16 and ×1.52 against 4: a pile's responses need more outer
  /// iterations with a slipping stick, and harder inner solves with a stiff one.
  double friction_penalty_ratio = 4.0;

  // --- Preconditioning (joint_system.cpp) ---------------------------------------------
  /// A fragment with at most this many free nodes gets a dense block of the response's
  /// operator, its contacts' terms included, as its preconditioner (BlockJacobi); larger
  /// ones keep their body's own. A 64-node block is 192×192, about 2.4 Mflop to factor
  /// once per outer iteration. At 32, the bunny at toughness 0 kept one fragment of 34–52
  /// nodes above it for most of the run, and with it the whole body's own preconditioner:
  /// the response took 3× the CG iterations of a run where no fragment was above it.
  Index dense_fragment_nodes = 64;
  /// An outer iteration whose solve took more conjugate-gradient iterations than this
  /// makes the rest of the response precondition each large fragment that a contact
  /// touches with a sparse block of its own, its contacts' terms included, in place of
  /// its body's own preconditioner, which cannot see them. The blocks cost sparse
  /// factorizations (per outer iteration; per response for a block over
  /// SparseBlocks::kKeptFactorNodes nodes), which pay only where the solves without them
  /// are long: on the bunny at toughness 0.2, while a fragment of hundreds of nodes lay
  /// among a hundred small ones, the response took 746 conjugate-gradient iterations per
  /// step without them and 263 with them; ordinary solves take 2-20 and never make them.
  /// A large value: never, for comparison.
  int sparse_blocks_after = 40;
  /// After a substep whose response ran long, this many more substeps make the sparse
  /// blocks before their first solve (the world is "in a pile", pile.h): in a
  /// pile, every response's first solve ran long again on its body's own preconditioner
  /// before the blocks took over (most of the response's conjugate-gradient iterations,
  /// and each of them a solve over the whole body). 0: never, for comparison.
  int sparse_block_memory = 16;

  // --- Debris (sequential_impulses.cpp) -----------------------------------------------
  /// The contacts of islands that read only small fragments and projectiles (a
  /// shattered body's debris) are answered by sequential impulses, at most this many
  /// sweeps; the rest, and all of them at 0, by the augmented Lagrangian. On the bunny at
  /// toughness 0, 16 sweeps made the step 0.57× as long with the same sphere
  /// penetration; 8 left more islands to the fallback below.
  int sequential_impulse_sweeps = 16;
  /// The sweeps' tolerance per contact is the augmented Lagrangian's, but never more
  /// than this share of its reach per step; at the cap their answer is kept if no
  /// contact falls short by more than that, else the augmented Lagrangian answers the
  /// island from the last step's impulses. On the bunny at toughness 0 at 16 sweeps, 0.1
  /// left so many islands to the fallback that the step took 37.5 ms against 29.4 at
  /// 0.25 (51.3 with no sweeps), at the same penetration
  /// (docs/decisions/0072-sequential-impulses-for-debris.md).
  double sequential_impulse_reach_share = 0.25;

  // --- Resting large fragments (rigid_response.cpp) ----------------------------------
  /// A large fragment that no projectile touches, whose contacts (with obstacles or other
  /// fragments) ask for at most this velocity change [m/s] (or twice one step of
  /// gravity, 2 |g| h, where that is more), and whose motion is rigid to within it, is
  /// answered as a rigid body
  /// (rigid_response.h); 0: never, every response deformable (the thesis's model). Over
  /// the sample's 12 variants 0.5 breaks off as much as the all-deformable model at
  /// 0.4–0.55× its step (docs/decisions/0073-rigid-answers-at-rest.md).
  double rigid_resting_speed = 0.5;

  // --- Small fragments as rigid bodies (rigid_response.cpp, World) --------------------
  /// A fragment of fewer tets than this moves as a rigid body: its contacts are answered
  /// as a rigid group's (rigid_response.h), and after each substep its deformation is
  /// dropped and its velocities made rigid (rigid_rotation.h, with the turn on the arc),
  /// so its strain stays what it was when it broke free (the moves only with the turns on
  /// arcs, WorldSettings::rotate_on_arcs); 0: none (the thesis's model). Off by default: at 2 (single tets, which cannot split again) the bunny's toughness 0
  /// lost its worst steps, but a chip just broken off still sinks up to 2 mm
  /// (docs/decisions/0074-small-fragments-move-rigidly.md).
  int rigid_fragments_below = 0;

  /// What a contact asking `required` [m/s] of the response may still miss its target by
  /// when the iterations stop: relative_violation of what it asks (or of
  /// `reference_speed`, |g| h), never more than reach_share of its reach per step.
  [[nodiscard]] double allowed_miss(double required, double reach, double dt, double reference_speed) const {
    const double allowed = relative_violation * std::max(std::abs(required), reference_speed);
    return reach > 0.0 ? std::min(allowed, reach_share * reach / dt) : allowed;
  }
  /// What sequential impulses may leave it short by at their cap (`allowed` for a point
  /// without reach); they stop at the smaller of this and `allowed`.
  [[nodiscard]] double acceptable_sweep_miss(double allowed, double reach, double dt) const {
    return reach > 0.0 ? sequential_impulse_reach_share * reach / dt : allowed;
  }
  /// The most a contact may ask [m/s] of a response that answers a fragment rigidly:
  /// rigid_resting_speed, or 2 |g| h (`reference_speed` is |g| h) where that is more.
  [[nodiscard]] double rigid_asked_speed(double reference_speed) const {
    return std::max(rigid_resting_speed, 2.0 * reference_speed);
  }
};

}  // namespace fissure::sim
