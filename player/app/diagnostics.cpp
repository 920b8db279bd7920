#include "player/app/diagnostics.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <tuple>

#include "common/log.h"

namespace fissure::player {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string obstacle_name(const sim::ObstacleHit& hit) {
  switch (hit.kind) {
    case sim::ObstacleHit::Kind::Ground: return "the ground";
    case sim::ObstacleHit::Kind::Box: return "box " + std::to_string(hit.index);
    case sim::ObstacleHit::Kind::Ball: return "sphere " + std::to_string(hit.index);
    case sim::ObstacleHit::Kind::Projectile: return "projectile " + std::to_string(hit.index);
    case sim::ObstacleHit::Kind::None: break;
  }
  return "nothing";
}

std::string describe(const sim::World& world, const sim::World::DeepestVertex& v) {
  return "vertex " + std::to_string(v.vertex) + " of '" + world.bodies()[v.body].name + "' (fragment " +
         std::to_string(v.fragment) + ") in " + obstacle_name(v.hit);
}
}  // namespace

double Diagnostics::total_energy(const sim::World& world) {
  return world.kinetic_energy() + world.elastic_energy() + world.potential_energy();
}

void Diagnostics::on_start(const sim::World& world) {
  const auto start = Clock::now();
  energy_initial = energy_max = energy_final = total_energy(world);
  energy_slack = 1e-9;
  m_body_energy_initial.clear();
  for (Index b = 0; b < world.bodies().size(); ++b) {
    const sim::ImplicitIntegrator& body = world.bodies()[b].integrator();
    const Vec3 extent = body.positions().rowwise().maxCoeff() - body.positions().rowwise().minCoeff();
    energy_slack += 1e-3 * body.node_masses().sum() * world.settings().step.gravity.norm() * extent.norm();
    m_body_energy_initial.push_back(world.body_energy(b).total());
  }
  momentum_initial = momentum_final = world.linear_momentum();
  angular_initial = angular_final = world.angular_momentum();
  seconds = seconds_since(start);
}

void Diagnostics::on_step(const sim::World& world, const sim::StepReport& report, long step) {
  const auto start = Clock::now();
  // What a viewer would see penetrate, only where something can be penetrated.
  if (world.settings().collisions) {
    sphere_penetration_final = world.sphere_penetration();
    const sim::World::DeepestVertex deepest = world.deepest_vertex();
    vertex_penetration_final = deepest.hit.depth;
    sphere_penetration_max = std::max(sphere_penetration_max, sphere_penetration_final);
    if (vertex_penetration_final > vertex_penetration_max) {
      vertex_penetration_max = vertex_penetration_final;
      vertex_penetration_where = describe(world, deepest);
    }
  }
  energy_final = total_energy(world);
  energy_max = std::max(energy_max, energy_final);
  energy_put_in = world.energy_put_in();
  const double input = energy_initial + energy_put_in;
  const double allowed = input + kEnergyTolerance * std::abs(input) + energy_slack;
  if (!std::isfinite(energy_final) && !m_stop) {
    m_stop = RunStop{"at step " + std::to_string(step) + " (t = " + std::to_string(world.time()) +
                         " s) the total energy became non-finite",
                     "use a smaller solver.dt or set solver.min_dt; please report the scene"};
  } else if (energy_final > allowed && energy_gain.empty()) {
    RunStop gain = energy_gain_stop(world, report, step, energy_final, allowed);
    energy_gain = gain.message;
    if (stop_on_energy_gain) m_stop = std::move(gain);
  }
  if (log_level() >= LogLevel::Debug) {
    log_debug("step " + std::to_string(step) + " kinetic " + std::to_string(world.kinetic_energy()) + " elastic " +
              std::to_string(world.elastic_energy()) + " gravity " + std::to_string(world.potential_energy()) +
              " contacts " + std::to_string(report.contacts.contacts) + " iterations " +
              std::to_string(report.solver_iterations));
  }
  seconds += seconds_since(start);
}

RunStop Diagnostics::energy_gain_stop(const sim::World& world, const sim::StepReport& report, long step,
                                      double energy, double allowed) const {
  // The body that gained the most since the start, and in which form.
  Index worst = kInvalidIndex;
  double gain = -std::numeric_limits<double>::infinity();
  for (Index b = 0; b < world.bodies().size(); ++b) {
    const double g = world.body_energy(b).total() - m_body_energy_initial[b];
    if (g > gain) std::tie(worst, gain) = std::pair(b, g);
  }
  std::string who = "the projectiles", cause = "contacts with projectiles";
  if (worst != kInvalidIndex) {
    const sim::BodyEnergy e = world.body_energy(worst);
    const bool elastic = e.elastic >= e.kinetic;
    const bool split = std::any_of(report.splits.begin(), report.splits.end(), [&](const auto& s) { return s.first == worst; });
    who = "body '" + world.bodies()[worst].name + "' (now " + std::to_string(e.kinetic) + " J kinetic, " +
          std::to_string(e.elastic) + " J elastic)";
    const double h = world.settings().step.dt / world.planned_substeps();
    if (split) {
      cause = "fracture: nodes split in this step and the two sides push apart";
    } else if (h > 1.0 / 60.0) {
      cause = "the large step, " + std::to_string(h) + " s (solver.dt and solver.max_substep): contacts lag within it";
    } else if (report.contacts.contacts > 0 && !elastic) {
      cause = "contacts pushing overlapping points apart";
    } else {
      cause = elastic ? "the implicit solve straining the body (a stiff or nearly incompressible material for this dt)"
                      : "the implicit solve";
    }
  }
  char amounts[160];
  std::snprintf(amounts, sizeof amounts, "the total energy %.6g J exceeds the %.6g J put in by more than %g%% (allowed %.6g J)",
                energy, energy_initial + energy_put_in, 100.0 * kEnergyTolerance, allowed);
  return {"at step " + std::to_string(step) + " (t = " + std::to_string(world.time()) + " s) " + amounts +
              "; the largest gain is " + who + "; likely cause: " + cause,
          "use a smaller solver.dt or solver.max_substep; the physics must not create energy, so please report "
          "the scene; --no-energy-check runs on to the end"};
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
