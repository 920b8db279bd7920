#pragma once
/// What a World step did (World::step): how it ended and, for reports, what each phase
/// took and what happened in it.

#include <cstdint>
#include <utility>
#include <vector>

#include "player/sim/contacts/collision.h"
#include "player/sim/fracture.h"
#include "player/sim/implicit_integrator.h"

namespace fissure::sim {

/// How a step ended. A step never throws for a numerical outcome: it says what
/// happened, and a failed step leaves the world exactly as it was before it.
enum class StepOutcome : std::uint8_t {
  Converged,    ///< one solve per body at dt (a CG solve may have hit its cap: see StepReport::unconverged)
  Substepped,   ///< taken in substeps: dt above max_substep, or a failed solve retried as halves (min_dt)
  SolveFailed,  ///< a solve failed even at the smallest dt allowed: the world is unchanged
  NonFinite,    ///< the step produced a non-finite position or velocity: the world is unchanged
};

struct StepStatus {
  StepOutcome outcome = StepOutcome::Converged;
  Index body = kInvalidIndex;                ///< the body whose solve failed or went non-finite (kInvalidIndex: a projectile)
  SolveStatus solve = SolveStatus::Converged;  ///< SolveFailed: why the body's solve failed
  double time = 0;                           ///< [s] start of the failed step
  double dt = 0;                             ///< [s] the step that failed (the smallest tried)
  [[nodiscard]] bool ok() const { return outcome == StepOutcome::Converged || outcome == StepOutcome::Substepped; }
};

/// What one step did, for reports.
struct StepReport {
  StepStatus status;
  double forces = 0, assembly = 0, solve = 0, fracture = 0, collisions = 0;  ///< [s] wall clock
  /// [s] the energy guard's own work (energy_guard.h): measuring each substep's energy,
  /// its exact re-solves where the substep gained, chips moved rigidly. The contacts a
  /// re-solve answers again count as collisions.
  double guard = 0;
  double total = 0;                 ///< [s] wall clock of the whole step, phases and what lies between
  int substeps = 1;                 ///< > 1 when adaptive stepping halved dt
  int solver_iterations = 0;        ///< summed over bodies and substeps
  int factorizations = 0;           ///< numeric Cholesky factorizations, summed likewise
  bool unconverged = false;         ///< a CG solve hit the iteration cap
  std::vector<std::pair<Index, NodeSplit>> splits;      ///< (body, split)
  std::vector<std::pair<Index, TetFace>> exposed;       ///< (body, face newly on the boundary)
  ContactCounts contacts;
  /// The smallest share of the contacts' restitution a substep kept: below 1 when the
  /// full restitution would have ended it above its energy budget (World::collide).
  double restitution_kept = 1.0;
  int exact_substeps = 0;    ///< substeps solved again exactly (WorldSettings::exact_when_gaining)
  int exact_iterations = 0;  ///< their Newton iterations, summed over bodies
  int energy_halvings = 0;   ///< substeps taken again as two halves because they gained energy
  int chips_moved_rigidly = 0;  ///< chips moved rigidly because they gained (WorldSettings::rigid_when_gaining_below)
  int exact_substeps_rejected = 0;  ///< of those, the ones whose contacts then gained more: the linear answer kept
  int stand_in_spheres = 0;  ///< spheres given to tets fracture exposed: stand-ins and the bake's reserve (stand_in_spheres.h)
  std::size_t fragments_asleep = 0;  ///< held still after the step (sleeping.h)
  int retaken_to_wake = 0;  ///< times the step was taken again because it closed on a sleeping island
};

}  // namespace fissure::sim
