#pragma once
/// The free spinning beam on which the exact and warped stiffness models differ most:
/// shared by the exact-stiffness tests and the trade-study sweep (fissure_tradeoff_sweep).

#include <algorithm>
#include <cmath>
#include <memory>

#include "player/sim/implicit_integrator.h"
#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"

namespace fissure::testing {

/// A 2 × 0.25 × 0.25 m beam of 8 × 1 × 1 cubes, free, about its centre.
struct SpinningBeam {
  TetMesh cage = grid_cage(Vec3::Zero(), Vec3(2.0, 0.25, 0.25), 8, 1, 1);
  Vec3 centre = cage.rest_positions.rowwise().mean();

  /// The beam stretched by `stretch` along x and spinning at ω about z through its centre.
  [[nodiscard]] std::unique_ptr<sim::ImplicitIntegrator> make(double stretch, double omega, double youngs = 1e5) const {
    auto body = std::make_unique<sim::ImplicitIntegrator>(cage.rest_positions, cage.tets,
                                                          sim::Material{.density = 1000, .youngs_modulus = youngs});
    Matrix3Xd x = cage.rest_positions;
    x.row(0) = (centre.x() + stretch * (cage.rest_positions.row(0).array() - centre.x())).matrix();
    body->set_positions(x);
    Matrix3Xd v(3, body->node_count());
    for (Index n = 0; n < body->node_count(); ++n) v.col(n) = Vec3(0, 0, omega).cross(x.col(n) - centre);
    body->set_velocities(v);
    return body;
  }
};

/// Where a spin run ended, relative to where it started.
struct SpinOutcome {
  Vec3 tip = Vec3::Zero(), tail = Vec3::Zero();  ///< mean of the nodes at x = 2 m and at x = 0
  double energy_ratio = 0;       ///< E / E0 at the end
  double peak_energy_ratio = 0;  ///< the largest E / E0 after any step
  double momentum_ratio = 0;     ///< L_z / L_z0 at the end
  int steps = 0;                 ///< steps taken; fewer than asked when a solve failed
};

/// The unstretched beam (E = 1 MPa) at 10 rad/s about z, with a little bending so the
/// elastic forces are not zero, run for `duration` seconds at step `dt` with `model`.
inline SpinOutcome spin(const SpinningBeam& beam, sim::StiffnessModel model, double dt, double duration) {
  auto body = beam.make(1.0, 10.0, 1e6);
  change_velocities(*body, [&](Matrix3Xd& v) {
    for (Index n = 0; n < body->node_count(); ++n) {
      const double s = beam.cage.rest_positions(0, n) - beam.centre.x();
      v(1, n) += 2.0 * s * s;
    }
  });
  sim::StepSettings settings;
  settings.dt = dt;
  settings.gravity.setZero();
  settings.stiffness = model;
  const double e0 = body->energy();
  const double l0 = body->angular_momentum().z();
  SpinOutcome out;
  out.peak_energy_ratio = 1.0;
  const auto steps = static_cast<int>(std::lround(duration / dt));
  for (; out.steps < steps; ++out.steps) {
    if (body->step(settings) != sim::SolveStatus::Converged) break;
    out.peak_energy_ratio = std::max(out.peak_energy_ratio, body->energy() / e0);
  }
  out.energy_ratio = body->energy() / e0;
  out.momentum_ratio = body->angular_momentum().z() / l0;
  int count = 0;
  for (Index n = 0; n < body->node_count(); ++n) {
    if (beam.cage.rest_positions(0, n) == 2.0) {
      out.tip += body->positions().col(n);
      ++count;
    }
    if (beam.cage.rest_positions(0, n) == 0.0) out.tail += body->positions().col(n);
  }
  out.tip /= count;
  out.tail /= count;
  return out;
}

}  // namespace fissure::testing
