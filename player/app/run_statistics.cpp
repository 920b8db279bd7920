#include "player/app/run_statistics.h"

#include <algorithm>
#include <cmath>

namespace fissure::player {

void PhaseStats::add(double seconds) {
  total += seconds;
  max = std::max(max, seconds);
  const double octaves = seconds > kSmallest ? std::log2(seconds / kSmallest) : 0.0;
  const auto last = static_cast<double>(buckets.size() - 1);
  ++buckets[static_cast<std::size_t>(std::clamp(std::floor(octaves * kBucketsPerOctave), 0.0, last))];
  ++count;
}

double PhaseStats::quantile(double q) const {
  if (count == 0) return 0.0;
  const auto rank = static_cast<std::uint64_t>(std::ceil(std::clamp(q, 0.0, 1.0) * static_cast<double>(count)));
  std::uint64_t seen = 0;
  for (std::size_t b = 0; b < buckets.size(); ++b) {
    seen += buckets[b];
    if (seen >= std::max<std::uint64_t>(rank, 1)) {
      // The bucket's geometric middle: within half a bucket (0.55 %) of any time in it.
      const double middle = kSmallest * std::exp2((static_cast<double>(b) + 0.5) / kBucketsPerOctave);
      return std::min(middle, max);
    }
  }
  return max;
}

void RunStatistics::on_start(const sim::World& world) {
  initial_nodes.clear();
  for (const sim::Body& b : world.bodies()) initial_nodes.push_back(b.integrator().node_count());
}

void RunStatistics::keep_if_slow(const sim::StepReport& r, long index) {
  if (slowest.size() == kSlowestKept && !(r.total > slowest.back().total)) return;
  const SlowStep slow{index,
                      r.total,
                      r.solve,
                      r.collisions,
                      r.fracture,
                      r.guard,
                      r.substeps,
                      r.exact_substeps,
                      r.energy_halvings,
                      r.factorizations,
                      r.retaken_to_wake,
                      r.splits.size()};
  const auto at = std::upper_bound(slowest.begin(), slowest.end(), slow,
                                   [](const SlowStep& a, const SlowStep& b) { return a.total > b.total; });
  slowest.insert(at, slow);
  if (slowest.size() > kSlowestKept) slowest.pop_back();
}

void RunStatistics::on_step(const sim::World& /*world*/, const sim::StepReport& r, long index) {
  keep_if_slow(r, index);
  step.add(r.total);
  forces.add(r.forces);
  assembly.add(r.assembly);
  solve.add(r.solve);
  fracture.add(r.fracture);
  collisions.add(r.collisions);
  guard.add(r.guard);
  splits += r.splits.size();
  exposed += r.exposed.size();
  contacts += r.contacts.contacts;
  swept += r.contacts.swept;
  response_iterations += r.contacts.response_iterations;
  response_sweeps += r.contacts.response_sweeps;
  rigid_answers += r.contacts.rigid_answers;
  unconverged += r.unconverged ? 1 : 0;
  iterations += r.solver_iterations;
  factorizations += r.factorizations;
  substeps_max = std::max(substeps_max, r.substeps);
  restitution_limited += r.restitution_kept < 1.0 ? 1 : 0;
  restitution_kept_min = std::min(restitution_kept_min, r.restitution_kept);
  exact_substeps += r.exact_substeps;
  exact_iterations += r.exact_iterations;
  exact_rejected += r.exact_substeps_rejected;
  energy_halvings += static_cast<std::size_t>(r.energy_halvings);
  chips_moved_rigidly += static_cast<std::size_t>(r.chips_moved_rigidly);
  stand_in_spheres += static_cast<std::size_t>(r.stand_in_spheres);
  fragments_asleep = r.fragments_asleep;
  retaken_to_wake += static_cast<std::size_t>(r.retaken_to_wake);
}

}  // namespace fissure::player
