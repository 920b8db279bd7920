#include "player/sim/contacts/rolling_resistance.h"

#include <Eigen/Cholesky>
#include <cmath>

namespace fissure::sim {
namespace {

/// One fragment's rigid spin: its angular momentum about its centre of mass and the
/// inverse of its inertia there. `spins` false: pinned or singular, it counts as still.
struct FragmentSpin {
  double mass = 0;
  Vec3 moment = Vec3::Zero();   ///< Σ m x, then the centre of mass
  Vec3 momentum = Vec3::Zero(); ///< Σ m v
  Vec3 angular = Vec3::Zero();  ///< L about the centre of mass
  Mat3 inertia = Mat3::Zero();
  Mat3 inverse_inertia = Mat3::Zero();
  Vec3 spin_before = Vec3::Zero();
  bool pinned = false, spins = false;
  [[nodiscard]] Vec3 spin() const { return inverse_inertia * angular; }
};

std::vector<FragmentSpin> fragment_spins(const SpinBody& body) {
  const Matrix3Xd& x = *body.positions;
  const Matrix3Xd& v = *body.velocities;
  const Eigen::VectorXd& m = *body.mass;
  std::vector<FragmentSpin> f(body.fragments);
  for (Eigen::Index n = 0; n < x.cols(); ++n) {
    FragmentSpin& s = f[body.node_fragment[n]];
    s.pinned = s.pinned || body.pinned[n] != 0;
    s.mass += m[n];
    s.moment += m[n] * x.col(n);
    s.momentum += m[n] * v.col(n);
  }
  for (FragmentSpin& s : f) {
    if (s.mass > 0.0) s.moment /= s.mass;
  }
  for (Eigen::Index n = 0; n < x.cols(); ++n) {
    FragmentSpin& s = f[body.node_fragment[n]];
    const Vec3 r = x.col(n) - s.moment;
    s.angular += m[n] * r.cross(v.col(n));
    s.inertia += m[n] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
  }
  for (FragmentSpin& s : f) {
    if (s.pinned || s.mass <= 0.0) continue;
    const Eigen::LLT<Mat3> factor(s.inertia);
    if (factor.info() != Eigen::Success) continue;
    s.inverse_inertia = factor.solve(Mat3::Identity());
    s.spins = s.inverse_inertia.allFinite();
    s.spin_before = s.spin();
  }
  return f;
}

/// The angular impulse τ (given to b, taken from a) of one contact: the share of the
/// one that equalises the two spins that its budget allows.
Vec3 resisting_impulse(const FragmentSpin* a, const FragmentSpin* b, double budget) {
  Vec3 relative = Vec3::Zero();
  Mat3 compliance = Mat3::Zero();
  if (a != nullptr) {
    relative += a->spin();
    compliance += a->inverse_inertia;
  }
  if (b != nullptr) {
    relative -= b->spin();
    compliance += b->inverse_inertia;
  }
  const Eigen::LLT<Mat3> factor(compliance);
  if (factor.info() != Eigen::Success) return Vec3::Zero();
  const Vec3 equalising = factor.solve(relative);
  const double size = equalising.norm();
  if (!(size > 0.0) || !std::isfinite(size)) return Vec3::Zero();
  return size <= budget ? equalising : (budget / size) * equalising;
}

}  // namespace

std::vector<Matrix3Xd> resist_rolling(std::span<const SpinBody> bodies, std::span<const RollingContact> contacts) {
  std::vector<std::vector<FragmentSpin>> spins;
  spins.reserve(bodies.size());
  for (const SpinBody& b : bodies) spins.push_back(fragment_spins(b));
  const auto side = [&](const SpinSide& s) -> FragmentSpin* {
    if (s.body == kInvalidIndex) return nullptr;
    FragmentSpin& f = spins[s.body][s.fragment];
    return f.spins ? &f : nullptr;
  };
  for (const RollingContact& c : contacts) {
    FragmentSpin* a = side(c.a);
    FragmentSpin* b = side(c.b);
    if ((a == nullptr && b == nullptr) || a == b || !(c.max_angular_impulse > 0.0)) continue;
    const Vec3 tau = resisting_impulse(a, b, c.max_angular_impulse);
    if (a != nullptr) a->angular -= tau;
    if (b != nullptr) b->angular += tau;
  }
  std::vector<Matrix3Xd> change(bodies.size());
  for (std::size_t bi = 0; bi < bodies.size(); ++bi) {
    const SpinBody& body = bodies[bi];
    change[bi] = Matrix3Xd::Zero(3, body.positions->cols());
    for (Eigen::Index n = 0; n < body.positions->cols(); ++n) {
      const FragmentSpin& f = spins[bi][body.node_fragment[n]];
      if (!f.spins) continue;
      const Vec3 spin_change = f.spin() - f.spin_before;
      change[bi].col(n) = spin_change.cross(body.positions->col(n) - f.moment);
    }
  }
  return change;
}

}  // namespace fissure::sim
