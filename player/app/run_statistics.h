#pragma once
/// Observer: what a run did, step by step — per-phase timings, solver and contact
/// counters, fracture events — for the console summary and the JSON report. Cheap: it
/// only adds up what each step's report already holds.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "player/app/run_loop.h"

namespace fissure::player {

struct PhaseStats {
  double total = 0, max = 0;  ///< [s]
  void add(double seconds);
  /// The q-quantile of the steps' times [s] (q ∈ [0, 1]; nearest rank), to within 1.1 %
  /// (a log histogram, so memory stays fixed however long the run), never above the
  /// slowest step; 0 with no step. A real-time budget is about the slow steps, not only
  /// the mean (issue 42: p99).
  [[nodiscard]] double quantile(double q) const;

  /// Buckets of 1/64 of an octave from 0.1 µs to about 0.1 µs × 2^36 (1.9 h); times
  /// outside go to the end buckets.
  static constexpr int kBucketsPerOctave = 64, kOctaves = 36;
  static constexpr double kSmallest = 1e-7;  ///< [s]
  std::vector<std::uint64_t> buckets = std::vector<std::uint64_t>(kBucketsPerOctave * kOctaves, 0);
  std::uint64_t count = 0;
};

/// One of a run's slowest steps and what it did: a real-time budget is broken by its
/// hitches, and their cause (a refactorization after fracture, an exact re-solve or a
/// halving of a substep that gained energy, a step taken again to wake a pile) is what
/// the report must say (issue 42).
struct SlowStep {
  long step = 0;  ///< the step's number in the run (1: the first)
  double total = 0, solve = 0, collisions = 0, fracture = 0, guard = 0;  ///< [s]
  int substeps = 1, exact_substeps = 0, energy_halvings = 0, factorizations = 0, retaken_to_wake = 0;
  std::size_t splits = 0;
};

class RunStatistics : public RunObserver {
 public:
  void on_start(const sim::World& world) override;
  void on_step(const sim::World& world, const sim::StepReport& report, long step) override;

  PhaseStats forces, assembly, solve, fracture, collisions, guard, step;
  std::size_t splits = 0, exposed = 0, contacts = 0, swept = 0, unconverged = 0, response_iterations = 0;
  std::size_t response_sweeps = 0;
  std::size_t rigid_answers = 0;  ///< large fragments at rest answered as rigid bodies, summed over responses
  long iterations = 0, factorizations = 0;
  int substeps_max = 1;
  /// Steps whose restitution was cut to keep a substep's energy budget, and the smallest
  /// share kept (sim::StepReport::restitution_kept).
  std::size_t restitution_limited = 0;
  double restitution_kept_min = 1.0;
  /// Substeps solved again exactly where the linear solve gained, their Newton
  /// iterations, and how many of them were dropped for the linear answer (sim::StepReport).
  std::size_t exact_substeps = 0, exact_iterations = 0, exact_rejected = 0;
  /// Substeps taken again as two halves because they still gained energy (sim::StepReport).
  std::size_t energy_halvings = 0;
  /// Chips moved rigidly because they gained energy (sim::StepReport::chips_moved_rigidly).
  std::size_t chips_moved_rigidly = 0;
  /// Spheres given to tets that fracture exposed with no collision point (sim::StepReport).
  std::size_t stand_in_spheres = 0;
  /// Fragments asleep after the last step, and steps taken again to wake an island (sim::StepReport).
  std::size_t fragments_asleep = 0, retaken_to_wake = 0;
  std::vector<Index> initial_nodes;  ///< per body
  /// The kSlowestKept slowest steps, slowest first (ties: the earlier step first).
  static constexpr std::size_t kSlowestKept = 5;
  std::vector<SlowStep> slowest;

 private:
  void keep_if_slow(const sim::StepReport& report, long step);
};

}  // namespace fissure::player
