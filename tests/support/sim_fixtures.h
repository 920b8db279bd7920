#pragma once
/// Small helpers shared by the physics tests.

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "common/tet_mesh.h"
#include "tests/support/procedural.h"
#include "player/sim/world.h"

namespace fissure::testing {

/// x with every coordinate moved by a uniform random amount in [−amount, amount].
inline Matrix3Xd perturbed(const Matrix3Xd& x, double amount, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-amount, amount);
  Matrix3Xd out = x;
  for (Eigen::Index i = 0; i < out.size(); ++i) out.data()[i] += u(rng);
  return out;
}

inline Mat3 rotation(double angle, const Vec3& axis) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

/// Changes a body's positions (or velocities) in place through `change(Matrix3Xd&)`.
template <typename Change>
void change_positions(sim::ImplicitIntegrator& body, Change&& change) {
  Matrix3Xd x = body.positions();
  change(x);
  body.set_positions(x);
}
template <typename Change>
void change_velocities(sim::ImplicitIntegrator& body, Change&& change) {
  Matrix3Xd v = body.velocities();
  change(v);
  body.set_velocities(v);
}

/// A body of the whole cage with the given material; everything else at its default.
inline sim::BodyDescription describe(const std::string& name, const TetMesh& cage, const sim::Material& material) {
  sim::BodyDescription d;
  d.name = name;
  d.rest = cage.rest_positions;
  d.tets = cage.tets;
  d.material = material;
  return d;
}

/// Everything a World is made of.
struct SceneParts {
  std::vector<sim::BodyDescription> bodies;
  sim::Environment environment;
  std::vector<sim::Projectile> projectiles;
  sim::WorldSettings settings;
  [[nodiscard]] std::unique_ptr<sim::World> make() const {
    return std::make_unique<sim::World>(bodies, environment, projectiles, settings);
  }
};

/// A 6×3×3 bar (324 tets: more than one 256-tet chunk per parallel loop) resting on the
/// ground, toughness 15 N, broken by a 3 kg ball at 40 m/s from t = 0.02 s; fracture and
/// self-collision on. Its first split comes a dozen steps in; after 100 steps it lies in
/// 3 fragments.
inline SceneParts breaking_bar() {
  const TetMesh cage = grid_cage(Vec3(0, 0, 0.05), Vec3(0.6, 0.3, 0.35), 6, 3, 3);
  SceneParts s;
  s.bodies.push_back(describe("bar", cage, sim::Material{.density = 1000, .youngs_modulus = 2e5, .poisson_ratio = 0.3}));
  s.bodies[0].toughness = 15.0;
  s.environment.ground = sim::Plane{};
  s.projectiles.push_back(sim::Projectile{.position = Vec3(0.3, 0.15, 1.5), .velocity = Vec3(0, 0, -40), .radius = 0.08,
                                          .mass = 3.0, .launch_time = 0.02, .material = {}, .launched = false});
  s.settings.fracture = true;
  s.settings.self_collision = true;
  return s;
}

}  // namespace fissure::testing
