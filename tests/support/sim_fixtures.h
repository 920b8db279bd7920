#pragma once
/// Small helpers shared by the physics tests.

#include <random>
#include <string>

#include "common/tet_mesh.h"
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

}  // namespace fissure::testing
