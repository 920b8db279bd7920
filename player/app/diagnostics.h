#pragma once
/// Observer: the physical checks a run reports — total energy (kinetic + elastic +
/// gravity) with its peak, momentum, and how deep collision spheres and render vertices
/// sink into obstacles. These cost a pass over every tet and every render vertex per
/// step, so they run only when asked (`run` asks by default; --no-diagnostics skips
/// them), and their own time is measured.

#include <optional>

#include "player/app/run_loop.h"

namespace fissure::player {

class Diagnostics : public RunObserver {
 public:
  void on_start(const sim::World& world) override;
  void on_step(const sim::World& world, const sim::StepReport& report, long step) override;
  void on_finish(const sim::World& world, const RunEnd& end) override;
  /// Stops the run when the total energy is no longer finite.
  [[nodiscard]] const RunStop* stop_request() const override { return m_stop ? &*m_stop : nullptr; }

  double energy_initial = 0, energy_final = 0, energy_max = 0;  ///< [J]
  double kinetic_final = 0, elastic_final = 0;                  ///< [J]
  Vec3 momentum_initial = Vec3::Zero(), momentum_final = Vec3::Zero();
  Vec3 angular_initial = Vec3::Zero(), angular_final = Vec3::Zero();
  double sphere_penetration_max = 0, vertex_penetration_max = 0;      ///< [m]
  double sphere_penetration_final = 0, vertex_penetration_final = 0;  ///< [m]
  double seconds = 0;  ///< spent in these checks [s]

 private:
  static double total_energy(const sim::World& world);
  std::optional<RunStop> m_stop;
};

}  // namespace fissure::player
