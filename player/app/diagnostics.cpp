#include "player/app/diagnostics.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "common/log.h"

namespace fissure::player {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }
}  // namespace

double Diagnostics::total_energy(const sim::World& world) {
  return world.kinetic_energy() + world.elastic_energy() + world.potential_energy();
}

void Diagnostics::on_start(const sim::World& world) {
  const auto start = Clock::now();
  energy_initial = energy_max = energy_final = total_energy(world);
  momentum_initial = momentum_final = world.linear_momentum();
  angular_initial = angular_final = world.angular_momentum();
  seconds = seconds_since(start);
}

void Diagnostics::on_step(const sim::World& world, const sim::StepReport& report, long step) {
  const auto start = Clock::now();
  // What a viewer would see penetrate, only where something can be penetrated.
  if (world.settings().collisions) {
    sphere_penetration_final = world.sphere_penetration();
    vertex_penetration_final = world.vertex_penetration();
    sphere_penetration_max = std::max(sphere_penetration_max, sphere_penetration_final);
    vertex_penetration_max = std::max(vertex_penetration_max, vertex_penetration_final);
  }
  energy_final = total_energy(world);
  energy_max = std::max(energy_max, energy_final);
  if (!std::isfinite(energy_final) && !m_stop) {
    m_stop = RunStop{"at step " + std::to_string(step) + " (t = " + std::to_string(world.time()) +
                         " s) the total energy became non-finite",
                     "use a smaller solver.dt or set solver.min_dt; please report the scene"};
  }
  if (log_level() >= LogLevel::Debug) {
    log_debug("step " + std::to_string(step) + " kinetic " + std::to_string(world.kinetic_energy()) + " elastic " +
              std::to_string(world.elastic_energy()) + " gravity " + std::to_string(world.potential_energy()) +
              " contacts " + std::to_string(report.contacts.contacts) + " iterations " +
              std::to_string(report.solver_iterations));
  }
  seconds += seconds_since(start);
}

void Diagnostics::on_finish(const sim::World& world, const RunEnd& /*end*/) {
  const auto start = Clock::now();
  energy_final = total_energy(world);
  kinetic_final = world.kinetic_energy();
  elastic_final = world.elastic_energy();
  momentum_final = world.linear_momentum();
  angular_final = world.angular_momentum();
  seconds += seconds_since(start);
}

}  // namespace fissure::player
