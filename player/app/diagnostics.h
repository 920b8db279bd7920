#pragma once
/// Observer: the physical checks a run reports — total energy (kinetic + elastic +
/// gravity) with its peak, momentum, and how deep collision spheres and render vertices
/// sink into obstacles. These cost a pass over every tet and every render vertex per
/// step, so they run only when asked (`run` asks by default; --no-diagnostics skips
/// them), and their own time is measured.

#include <optional>
#include <string>
#include <vector>

#include "player/app/run_loop.h"

namespace fissure::player {

class Diagnostics : public RunObserver {
 public:
  void on_start(const sim::World& world) override;
  void on_step(const sim::World& world, const sim::StepReport& report, long step) override;
  void on_finish(const sim::World& world, const RunEnd& end) override;
  /// Stops the run when the total energy is no longer finite, or exceeds what was put in
  /// (the start plus World::energy_put_in()) by more than kEnergyTolerance of it plus
  /// energy_slack: the physics may only lose energy (issue 16), so a gain is a fault,
  /// named with its step, body and likely cause.
  [[nodiscard]] const RunStop* stop_request() const override { return m_stop ? &*m_stop : nullptr; }

  double energy_initial = 0, energy_final = 0, energy_max = 0;  ///< [J]
  double kinetic_final = 0, elastic_final = 0;                  ///< [J]
  Vec3 momentum_initial = Vec3::Zero(), momentum_final = Vec3::Zero();
  Vec3 angular_initial = Vec3::Zero(), angular_final = Vec3::Zero();
  double sphere_penetration_max = 0, vertex_penetration_max = 0;      ///< [m]
  double sphere_penetration_final = 0, vertex_penetration_final = 0;  ///< [m]
  /// Where the deepest render vertex of the run was: "vertex 812 of 'bunny' (fragment 3)
  /// in the ground"; empty if none sank.
  std::string vertex_penetration_where;
  double seconds = 0;  ///< spent in these checks [s]
  /// The share of the energy put in that a run may gain before it is stopped: rounding,
  /// and CG solves that stop at their tolerance, move the total by far less.
  static constexpr double kEnergyTolerance = 0.01;
  /// [J] the absolute part of the bound: lifting every body by 0.1% of its size.
  double energy_slack = 0;
  double energy_put_in = 0;  ///< [J] by the end (World::energy_put_in())
  bool stop_on_energy_gain = true;  ///< false: a gain is reported (energy_gain) but the run goes on
  std::string energy_gain;          ///< the first gain's message, empty if none

 private:
  static double total_energy(const sim::World& world);
  /// The stop for an energy gain: who gained it, and the likely cause.
  [[nodiscard]] RunStop energy_gain_stop(const sim::World& world, const sim::StepReport& report, long step,
                                         double energy, double allowed) const;
  std::optional<RunStop> m_stop;
  std::vector<double> m_body_energy_initial;  ///< [J] per body
};

}  // namespace fissure::player
