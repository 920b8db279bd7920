#pragma once
/// What the viewer's panel shows and edits: the drawing features, the clock, the next
/// shot, and per-step timings and counters kept for the plots.

#include <array>
#include <deque>
#include <string>

#include "player/app/run_loop.h"

namespace fissure::view {

struct Features {
  bool walls = true, normal_mapping = true, tessellation = false, cage = false, spheres = false,
       replication_colors = false, fragment_colors = false;
  /// The feature named as view_script.h names it; null for an unknown name.
  bool* find(const std::string& name);
};

struct Shot {
  float mass = 2.0f;    ///< [kg]
  float radius = 0.05f; ///< [m]
  float speed = 15.0f;  ///< [m/s]
};

/// Observer: the last steps' phase times [ms] and counters, for the panel's plots.
class StepHistory : public player::RunObserver {
 public:
  static constexpr std::size_t kLength = 240;
  enum Phase { Forces, Solve, Fracture, Collisions, Guard, Step, PhaseCount };
  static constexpr std::array<const char*, PhaseCount> kPhaseNames{"forces + assembly", "solve", "fracture",
                                                                   "collisions", "energy guard", "step"};

  void on_step(const sim::World& world, const sim::StepReport& report, long step) override;

  std::array<std::deque<float>, PhaseCount> ms;
  long splits = 0;        ///< since the start
  long contacts = 0;      ///< the last step's
  long steps = 0;
};

}  // namespace fissure::view
