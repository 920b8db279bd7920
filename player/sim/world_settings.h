#pragma once
/// What a World is told: the step, the features a scene turns on, and the energy guard's
/// and contacts' tuning values (World::set_settings applies new ones between steps).

#include <cstdint>

#include "player/sim/contacts/contact_settings.h"
#include "player/sim/contacts/sleeping.h"
#include "player/sim/implicit_integrator.h"

namespace fissure::sim {

/// Which points of a body meet obstacles and each other: the bake's collision spheres, or
/// every render vertex (exact to the render surface, and slower).
enum class CollisionPoints { Spheres, RenderVertices };

/// Which energy-gaining substeps World solves again exactly (WorldSettings::exact_when_gaining).
enum class ExactResolve : std::uint8_t { Never, Solve, SolveAndContacts };

struct WorldSettings {
  StepSettings step;
  double min_dt = 0;  ///< > 0: a step whose solve fails is retried as two halves, down to this
  /// A step longer than this is taken as equal substeps no longer than it, each with its
  /// own fracture and contacts (0: never). Scenes default to 1/60 s (formats/scene.h):
  /// the sample bunny hit by its ball keeps the energy bound at 1/60 s and gains ×1.3e13
  /// at 1/30 s (docs/decisions/0030-energy-check-per-run.md). The world itself steps
  /// what it is told.
  double max_substep = 0.0;
  bool fracture = false;
  int max_splits_per_step = 64;  ///< per substep: each substep runs fracture
  bool collisions = true;
  bool self_collision = false;
  CollisionPoints collision_points = CollisionPoints::Spheres;
  /// The contacts' tuning values (contact_settings.h); a scene sets contact_iterations
  /// and contact_sweeps from its [solver] table.
  ContactSettings contacts;
  /// Each fragment's rigid rotation within a step moves on an arc, not a line
  /// (rigid_rotation.h); off: plain backward Euler, for comparison.
  bool rotate_on_arcs = true;
  /// Restitution gives back at most what a substep would otherwise lose (World::collide);
  /// off: Newton's rule on every contact alone, for comparison.
  bool restitution_within_budget = true;
  /// In a pile (pile.h: a contact response ran long, or swept its debris to the cap,
  /// within contacts.sparse_block_memory substeps), after a substep whose inelastic
  /// answer ended above its budget anyway, the next substep answers inelastically first
  /// and restitution only if there is room (World::collide); off: restitution first
  /// always, for comparison.
  bool inelastic_first_in_piles = true;
  /// A substep that ends above its energy budget (its start's energy plus what was put in)
  /// is solved again exactly (ImplicitIntegrator::solve_exactly) where its linear solve
  /// gained: from that answer turned on arcs, with its contacts answered again (Solve); and
  /// also where its contact response gained, with that response's impulses held
  /// (SolveAndContacts). See EnergyGuard::solve_exactly_if_gaining for what each fixes and what
  /// the second still breaks. Paid only in substeps that would otherwise create energy.
  ExactResolve exact_when_gaining = ExactResolve::Solve;
  int exact_iterations = 30;  ///< Newton iterations at most per body and exact substep
  /// A substep whose gain is at most this share of what the run has dissipated so far
  /// (the run's bound less the substep's own) is not solved again exactly: the run's
  /// bound, which the halvings below keep, still holds, and each such substep can spend
  /// at most this share of what is left. 0: every gain is solved again. The re-solve is
  /// Newton iterations over the whole body: on the sample in the 10,024-tet cage, seven
  /// gains of 6 µJ–11 mJ (at most 0.04 % of the run's 30 J dissipated) took 0.4–1.7 s
  /// each, the run's slowest steps (issue 42;
  /// docs/decisions/0057-exact-resolve-above-a-share-of-what-was-dissipated.md).
  double exact_gain_share = 0.01;
  /// A substep that still ends above its energy budget after the exact re-solve, and
  /// above all the world was given, has its chips of fewer tets than this that gained
  /// energy in it moved rigidly (EnergyGuard::move_gaining_chips_rigidly): their shape at the
  /// substep's start moved and turned, their velocities made rigid. A few-tet fragment
  /// of a nearly incompressible material is where the linear solve runs away
  /// (ν = 0.4999: 143 kJ from 37.6 J given, 14.3 J of it in one tet of a 3-tet chip a
  /// split had just made), and no halving of the step stops it
  /// (docs/decisions/0075-chips-that-gain-move-rigidly.md). 0: never.
  int rigid_when_gaining_below = 8;
  /// A substep that still ends above its energy budget after the repairs above, and
  /// above all the world was given (its energy when built plus what was put in since),
  /// is taken again as two halves from its start, at most this many times in a row (so
  /// down to dt / 2^energy_halvings, and never below min_dt); 0: never. Step-size
  /// control with the run's energy bound as the tolerance: what the repairs leave is the
  /// large step's own error (contact corrections moved on lines, light stiff fragments
  /// landing at km/s), which shrinks with the step. Gains that stay within what earlier
  /// steps dissipated are let through: on the sample scene the strict per-substep test
  /// halved 492 substeps for gains of at most 2.7 mJ, doubling its cost, in a run that
  /// never came within 0.6 J of its bound. 6 keeps both stability grids within the bound
  /// in every case (docs/decisions/0033-halving-substeps-that-gain.md).
  int energy_halvings = 6;
  /// Islands of fragments at rest are held still until something closes on them
  /// (sleeping.h); speed 0: never.
  SleepSettings sleep;
};

}  // namespace fissure::sim
