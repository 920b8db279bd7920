#include "player/sim/contacts/stand_in_spheres.h"

#include <algorithm>
#include <cmath>

#include "common/assert.h"
#include "common/tet_mesh.h"

namespace fissure::sim {

namespace {

/// A stand-in's centre moves towards the centroid when the sphere that fits there is
/// smaller than this share of the centroid's.
constexpr double kLeastFitShare = 0.1;

/// A tet's volume and the area of each face, face i opposite corner i (kTetFaceNodes).
std::pair<double, Vec4> volume_and_face_areas(const Matrix3Xd& rest, const Matrix4Xu& tets, TetIndex t) {
  Mat3 edges;
  const Vec3 x0 = rest.col(tets(0, t));
  edges << rest.col(tets(1, t)) - x0, rest.col(tets(2, t)) - x0, rest.col(tets(3, t)) - x0;
  Vec4 areas;
  for (int i = 0; i < 4; ++i) {
    const auto& face = kTetFaceNodes[i];
    const Vec3 a = rest.col(tets(face[0], t)), b = rest.col(tets(face[1], t)), c = rest.col(tets(face[2], t));
    areas[i] = 0.5 * (b - a).cross(c - a).norm();
  }
  return {edges.determinant() / 6.0, areas};
}

}  // namespace

EmbeddedPoints inscribed_spheres(const Matrix3Xd& rest, const Matrix4Xu& tets) {
  // The centroid is a quarter of each face's height from that face, so the radius is
  // 3V / (4 · largest face area). (The inradius 3V / total area is larger whenever a face
  // exceeds a quarter of the total: it poked out of the Kuhn tets of a grid by 0.03 of
  // the edge, so face neighbours' spheres overlapped, and the moment fracture put them
  // in different fragments, self-collision threw them apart.)
  EmbeddedPoints points;
  for (TetIndex t = 0; t < static_cast<TetIndex>(tets.cols()); ++t) {
    const auto [volume, areas] = volume_and_face_areas(rest, tets, t);
    points.tet.push_back(t);
    points.barycentric.push_back(Vec4::Constant(0.25));
    points.radius.push_back(3.0 * volume / (4.0 * areas.maxCoeff()));
  }
  return points;
}

StandInSpheres::StandInSpheres(const Matrix3Xd& rest, const Matrix4Xu& tets, const EmbeddedPoints& points,
                               const MassDistribution* mass, const EmbeddedPoints& reserve,
                               std::span<const TetIndex> reserve_cover) {
  const auto tet_count = static_cast<std::size_t>(tets.cols());
  hold_reserve(tets, reserve, reserve_cover);
  m_barycentric.assign(tet_count, Vec4::Constant(0.25));
  m_radius.assign(tet_count, 0.0);
  m_given.assign(tet_count, 0);
  std::vector<std::uint8_t> has_point(tet_count, 0);
  for (const TetIndex t : points.tet) has_point[t] = 1;
  for (std::size_t t = 0; t < tet_count; ++t) {
    const double fraction = mass != nullptr ? mass->fraction[t] : 1.0;
    if (has_point[t] || !(fraction > 0.0)) continue;
    // The distance from barycentric b to the face opposite corner i is b_i times that
    // corner's height, 3V / A_i.
    const auto [volume, areas] = volume_and_face_areas(rest, tets, static_cast<TetIndex>(t));
    const Vec4 heights = 3.0 * volume * areas.cwiseInverse();
    const auto fits = [&](const Vec4& b) { return b.cwiseProduct(heights).minCoeff(); };
    if (mass != nullptr) m_barycentric[t] = mass->center_of_mass[t];
    // A sliver of solid along a face has its centre of mass on that face, where no
    // sphere fits: its reserve had radius 0, so it got none, and a one-tet fragment of it
    // would fall through the ground. Halfway to the centroid, one fits at least half as
    // large as there.
    const Vec4 centroid = Vec4::Constant(0.25);
    if (fits(m_barycentric[t]) < kLeastFitShare * fits(centroid)) m_barycentric[t] = 0.5 * (m_barycentric[t] + centroid);
    m_radius[t] = std::cbrt(std::min(fraction, 1.0)) * std::max(fits(m_barycentric[t]), 0.0);
  }
}

namespace {

/// How many nodes tets a and b share.
int shared_nodes(const Matrix4Xu& tets, TetIndex a, TetIndex b) {
  int shared = 0;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) shared += tets(i, a) == tets(j, b) ? 1 : 0;
  }
  return shared;
}

}  // namespace

void StandInSpheres::hold_reserve(const Matrix4Xu& tets, const EmbeddedPoints& reserve, std::span<const TetIndex> cover) {
  FISSURE_ASSERT(cover.size() == reserve.size());
  const auto tet_count = static_cast<std::size_t>(tets.cols());
  m_reserve = reserve;
  m_reserve_cover.assign(cover.begin(), cover.end());
  m_reserve_given.assign(reserve.size(), 0);
  m_reserve_shared.assign(reserve.size(), 0);
  for (std::size_t k = 0; k < reserve.size(); ++k) {
    if (cover[k] != kInvalidIndex) m_reserve_shared[k] = static_cast<std::uint8_t>(shared_nodes(tets, reserve.tet[k], cover[k]));
  }
  // Those whose tet does not touch its cover tet (or has none) come with its exposure.
  m_exposed_start.assign(tet_count + 1, 0);
  for (std::size_t k = 0; k < reserve.size(); ++k) m_exposed_start[reserve.tet[k] + 1] += m_reserve_shared[k] == 0;
  for (std::size_t t = 0; t < tet_count; ++t) m_exposed_start[t + 1] += m_exposed_start[t];
  m_exposed.resize(m_exposed_start.back());
  std::vector<std::size_t> next(m_exposed_start.begin(), m_exposed_start.end() - 1);
  for (std::size_t k = 0; k < reserve.size(); ++k) {
    if (m_reserve_shared[k] == 0) m_exposed[next[reserve.tet[k]]++] = k;
  }
}

void StandInSpheres::give(std::size_t reserve, EmbeddedPoints& points) {
  if (m_reserve_given[reserve]) return;
  m_log.push_back({points.size(), false, reserve});
  m_obstacles_only.resize(points.size() + 1, 0);
  m_obstacles_only.back() = 1;
  points.tet.push_back(m_reserve.tet[reserve]);
  points.barycentric.push_back(m_reserve.barycentric[reserve]);
  points.radius.push_back(m_reserve.radius[reserve]);
  m_reserve_given[reserve] = 1;
}

std::size_t StandInSpheres::add_for(std::span<const TetFace> exposed, const Matrix4Xu& tets,
                                    std::span<const Index> tet_fragment, EmbeddedPoints& points) {
  const std::size_t before = points.size();
  for (const TetFace& face : exposed) {
    const TetIndex t = face.tet;
    if (t >= m_radius.size()) continue;
    if (m_radius[t] > 0.0 && !m_given[t]) {
      m_log.push_back({points.size(), true, t});
      points.tet.push_back(t);
      points.barycentric.push_back(m_barycentric[t]);
      points.radius.push_back(m_radius[t]);
      m_given[t] = 1;
    }
    for (std::size_t i = m_exposed_start[t]; i < m_exposed_start[t + 1]; ++i) give(m_exposed[i], points);
  }
  // Fracture splits nodes and exposes faces together: no exposure, no new parting.
  if (exposed.empty()) return points.size() - before;
  for (std::size_t k = 0; k < m_reserve.size(); ++k) {
    const TetIndex t = m_reserve.tet[k], cover = m_reserve_cover[k];
    if (m_reserve_given[k] || cover == kInvalidIndex) continue;
    const bool split_between = m_reserve_shared[k] > 0 && shared_nodes(tets, t, cover) < m_reserve_shared[k];
    if (split_between || tet_fragment[t] != tet_fragment[cover]) give(k, points);
  }
  return points.size() - before;
}

void StandInSpheres::truncate(EmbeddedPoints& points, std::size_t count) {
  while (!m_log.empty() && m_log.back().point >= count) {
    const Given& g = m_log.back();
    (g.stand_in ? m_given : m_reserve_given)[g.index] = 0;
    m_log.pop_back();
  }
  m_obstacles_only.resize(std::min(count, m_obstacles_only.size()));
  points.tet.resize(std::min(count, points.size()));
  points.barycentric.resize(points.tet.size());
  points.radius.resize(points.tet.size());
}

std::size_t StandInSpheres::reserved() const {
  std::size_t count = 0;
  for (std::size_t t = 0; t < m_radius.size(); ++t) count += m_radius[t] > 0.0 && !m_given[t] ? 1 : 0;
  for (const std::uint8_t given : m_reserve_given) count += given ? 0 : 1;
  return count;
}

}  // namespace fissure::sim
