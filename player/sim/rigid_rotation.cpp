#include "player/sim/rigid_rotation.h"

#include <Eigen/Geometry>
#include <cmath>
#include <vector>

namespace fissure::sim {
namespace {

/// What one fragment's rigid fit needs, summed over its nodes.
struct GroupFit {
  double mass = 0;
  Vec3 start_moment = Vec3::Zero(), displacement_moment = Vec3::Zero(), momentum = Vec3::Zero();
  Mat3 inertia = Mat3::Zero();
  Vec3 angular = Vec3::Zero();  ///< Σ m r × (d − u)
  Vec3 momentum_before = Vec3::Zero(), momentum_after = Vec3::Zero();  ///< angular, about the new centre
  Mat3 inertia_after = Mat3::Zero();
  bool pinned = false;
  // The results.
  Vec3 centre = Vec3::Zero(), translation = Vec3::Zero(), velocity = Vec3::Zero();
  Eigen::AngleAxisd rotation = Eigen::AngleAxisd::Identity();
  Vec3 rotation_vector = Vec3::Zero();
};

/// Below this the arc and the line differ by less than rounding: leave the fragment alone.
constexpr double kSmallestRotation = 1e-12;

/// Turning the velocities with the body turns its angular momentum too, which a free
/// body keeps in the world frame (a tumbling body's spin axis precesses about it):
/// measured on a steel bar tumbling about a non-principal axis, |ΔL|/|L| = 0.38 after
/// 60 steps of 0.01 s. So each fragment's rigid spin is replaced by the one carrying the
/// angular momentum the step gave it, ω = I⁻¹ L, about the turned body. That alone is
/// the explicit Lie–Euler rotation step, which gains energy (the same bar: ×3.2 in 60
/// steps of 0.05 s). Where it would gain, the spin is scaled down to the energy the
/// turned velocities had: L keeps its direction and loses some magnitude, and the
/// kinetic energy never rises (the spin's energy ½ L·I⁻¹L is its only change, the
/// rigid spin being orthogonal to the rest of the velocities in the mass metric).
void keep_angular_momentum(const std::vector<GroupFit>& fits, std::span<const Index> group, const Matrix3Xd& positions,
                           Matrix3Xd& velocities) {
  std::vector<Vec3> correction(fits.size(), Vec3::Zero());
  for (std::size_t k = 0; k < fits.size(); ++k) {
    const GroupFit& g = fits[k];
    if (g.pinned || g.rotation.angle() == 0.0) continue;
    const Eigen::LLT<Mat3> factor(g.inertia_after);
    if (factor.info() != Eigen::Success) continue;
    const Vec3 spin_now = factor.solve(g.momentum_after), spin_kept = factor.solve(g.momentum_before);
    const double energy_now = g.momentum_after.dot(spin_now), energy_kept = g.momentum_before.dot(spin_kept);
    const double scale = energy_kept > energy_now ? std::sqrt(energy_now / energy_kept) : 1.0;
    correction[k] = scale * spin_kept - spin_now;
  }
  for (Eigen::Index n = 0; n < positions.cols(); ++n) {
    const GroupFit& g = fits[group[n]];
    if (g.pinned || g.rotation.angle() == 0.0) continue;
    velocities.col(n) += correction[group[n]].cross(positions.col(n) - g.centre - g.translation);
  }
}

/// A rigid group's velocities made the rigid field that carries their momentum and
/// angular momentum, V + Ω × r with I Ω = L about the group's centre: a projection in
/// the mass metric, so the kinetic energy never rises.
void keep_rigid(const std::vector<GroupFit>& fits, std::span<const std::uint8_t> rigid, const Eigen::VectorXd& mass,
                std::span<const Index> group, const Matrix3Xd& positions, Matrix3Xd& velocities) {
  const std::size_t count = fits.size();
  std::vector<Vec3> centre(count, Vec3::Zero()), momentum(count, Vec3::Zero()), angular(count, Vec3::Zero());
  std::vector<double> total(count, 0.0);
  std::vector<Mat3> inertia(count, Mat3::Zero());
  for (Eigen::Index n = 0; n < positions.cols(); ++n) {
    const Index g = group[n];
    if (!rigid[g] || fits[g].pinned) continue;
    total[g] += mass[n];
    centre[g] += mass[n] * positions.col(n);
    momentum[g] += mass[n] * velocities.col(n);
  }
  for (std::size_t g = 0; g < count; ++g) {
    if (total[g] > 0.0) centre[g] /= total[g];
  }
  for (Eigen::Index n = 0; n < positions.cols(); ++n) {
    const Index g = group[n];
    if (!rigid[g] || fits[g].pinned || !(total[g] > 0.0)) continue;
    const Vec3 r = positions.col(n) - centre[g];
    inertia[g] += mass[n] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
    angular[g] += mass[n] * r.cross(velocities.col(n) - momentum[g] / total[g]);
  }
  std::vector<Vec3> spin(count, Vec3::Zero());
  for (std::size_t g = 0; g < count; ++g) {
    // Collinear nodes have no inertia about their line: no spin about it either.
    const Eigen::LDLT<Mat3> factor(inertia[g]);
    if (total[g] > 0.0 && factor.info() == Eigen::Success) spin[g] = factor.solve(angular[g]);
    if (!spin[g].allFinite()) spin[g].setZero();
  }
  for (Eigen::Index n = 0; n < positions.cols(); ++n) {
    const Index g = group[n];
    if (!rigid[g] || fits[g].pinned || !(total[g] > 0.0)) continue;
    velocities.col(n) = momentum[g] / total[g] + spin[g].cross(positions.col(n) - centre[g]);
  }
}

}  // namespace

double rotate_rigid_parts(const Matrix3Xd& start, const Eigen::VectorXd& mass, std::span<const std::uint8_t> pinned,
                          std::span<const Index> group, Index group_count, Matrix3Xd& positions,
                          Matrix3Xd& velocities, std::span<const std::uint8_t> rigid) {
  const Eigen::Index n_nodes = positions.cols();
  std::vector<GroupFit> fits(group_count);
  for (Eigen::Index n = 0; n < n_nodes; ++n) {
    GroupFit& g = fits[group[n]];
    g.pinned = g.pinned || pinned[n] != 0;
    g.mass += mass[n];
    g.start_moment += mass[n] * start.col(n);
    g.displacement_moment += mass[n] * (positions.col(n) - start.col(n));
    g.momentum += mass[n] * velocities.col(n);
  }
  for (GroupFit& g : fits) {
    if (g.pinned || g.mass <= 0.0) continue;
    g.centre = g.start_moment / g.mass;
    g.translation = g.displacement_moment / g.mass;
    g.velocity = g.momentum / g.mass;
  }
  for (Eigen::Index n = 0; n < n_nodes; ++n) {
    GroupFit& g = fits[group[n]];
    if (g.pinned) continue;
    const Vec3 r = start.col(n) - g.centre;
    g.inertia += mass[n] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
    g.angular += mass[n] * r.cross(positions.col(n) - start.col(n) - g.translation);
    g.momentum_before += mass[n] * (positions.col(n) - g.centre - g.translation).cross(velocities.col(n) - g.velocity);
  }
  double largest = 0.0;
  for (GroupFit& g : fits) {
    if (g.pinned || g.mass <= 0.0) continue;
    // A fragment whose nodes are collinear cannot define a rotation about that line:
    // an inertia tensor without a positive-definite factor leaves it as it is.
    const Eigen::LLT<Mat3> factor(g.inertia);
    if (factor.info() != Eigen::Success) continue;
    g.rotation_vector = factor.solve(g.angular);
    const double angle = g.rotation_vector.norm();
    if (!(angle > kSmallestRotation)) continue;  // also skips a non-finite fit
    g.rotation = Eigen::AngleAxisd(angle, g.rotation_vector / angle);
    largest = std::max(largest, angle);
  }
  const auto is_rigid = [&](Index g) { return !rigid.empty() && rigid[g] != 0; };
  for (Eigen::Index n = 0; n < n_nodes; ++n) {
    GroupFit& g = fits[group[n]];
    if (g.pinned || g.mass <= 0.0) continue;
    const bool turns = g.rotation.angle() != 0.0;
    if (!turns && !is_rigid(group[n])) continue;
    const Vec3 r = start.col(n) - g.centre;
    // A rigid group keeps no deformation: the start's shape, moved and turned, so its
    // strain is the start's.
    const Vec3 deformation = is_rigid(group[n]) ? Vec3::Zero()
                                                : Vec3(positions.col(n) - start.col(n) - g.translation - g.rotation_vector.cross(r));
    positions.col(n) = g.centre + g.translation + g.rotation * (r + deformation);
    velocities.col(n) = g.velocity + g.rotation * (velocities.col(n) - g.velocity);
    const Vec3 r_after = positions.col(n) - g.centre - g.translation;
    g.momentum_after += mass[n] * r_after.cross(velocities.col(n) - g.velocity);
    g.inertia_after += mass[n] * (r_after.squaredNorm() * Mat3::Identity() - r_after * r_after.transpose());
  }
  keep_angular_momentum(fits, group, positions, velocities);
  if (!rigid.empty()) keep_rigid(fits, rigid, mass, group, positions, velocities);
  return largest;
}

std::vector<std::uint8_t> small_fragments(std::span<const Index> tet_fragment, Index fragment_count, int below) {
  if (below <= 0) return {};
  std::vector<Index> tets(fragment_count, 0);
  for (const Index f : tet_fragment) ++tets[f];
  std::vector<std::uint8_t> small(fragment_count);
  for (Index f = 0; f < fragment_count; ++f) small[f] = tets[f] < static_cast<Index>(below);
  return small;
}

}  // namespace fissure::sim
