#include "player/sim/contacts/collision.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "player/sim/contacts/contact_response.h"
#include "player/sim/contacts/rolling_resistance.h"

namespace fissure::sim {

namespace {

struct Contact {
  ContactSide a, b;
  Vec3 normal;             ///< from b towards a
  double reach = 0;        ///< a and b touch when normal · (a − b) = reach
  double gap = 0;          ///< normal · (a − b) − reach at the start of the step
  double restitution = 0, friction = 0;
};

ContactMaterial combine(const ContactMaterial& a, const ContactMaterial& b) {
  return {std::max(a.restitution, b.restitution), std::sqrt(a.friction * b.friction),
          std::sqrt(a.rolling_resistance * b.rolling_resistance)};
}

/// The required normal relative velocity of a contact (Box2D's speculative contacts):
/// it may close its start-of-step gap during the step but not cross it, vₙ ≥ −gap / h.
/// An overlap left from earlier steps is pushed out at a share of its depth per step, no
/// faster than a cap (ContactSettings::push_out_share, max_push_out_speed). Restitution
/// applies only above a resting speed, so resting contact does not jitter. Returns the
/// target without restitution and with it.
std::pair<double, double> contact_targets(const Contact& c, double approach, const CollisionSettings& settings) {
  const double h = settings.dt;
  const double resting_speed = 2.0 * settings.gravity.norm() * h;
  const double speculative = c.gap >= 0.0 ? -c.gap / h
                                          : std::min(-settings.contacts.push_out_share * c.gap / h,
                                                     settings.contacts.max_push_out_speed);
  const bool impact = approach < -resting_speed && approach < speculative;
  return {speculative, impact ? std::max(speculative, -c.restitution * approach) : speculative};
}

ContactSide embedded_side(std::span<const CollisionBody> bodies, Index body, Index point) {
  const EmbeddedPoints& points = *bodies[body].points;
  return {ContactSide::Kind::Embedded, body, point, points.tet[point], points.barycentric[point]};
}

/// Rolling resistance's view of a side: an embedded point's fragment, or no spin.
SpinSide spin_side(const ContactSide& s, std::span<const CollisionBody> bodies) {
  if (s.kind != ContactSide::Kind::Embedded) return {};
  const std::vector<Index>* tet_fragment = bodies[s.owner].tet_fragment;
  return {s.owner, tet_fragment != nullptr ? (*tet_fragment)[s.tet] : 0};
}

/// Each node's fragment (a node belongs to the tets that hold it, all of one fragment);
/// returns the number of fragments.
Index fragments_of_nodes(const ImplicitIntegrator& body, const std::vector<Index>* tet_fragment,
                         std::vector<Index>& node_fragment) {
  const Matrix4Xu& tets = body.elasticity().tets();
  node_fragment.assign(body.node_count(), 0);
  if (tet_fragment == nullptr) return 1;  // not split: one piece
  Index fragments = 0;
  for (Eigen::Index t = 0; t < tets.cols(); ++t) {
    for (int k = 0; k < 4; ++k) node_fragment[tets(k, t)] = (*tet_fragment)[t];
    fragments = std::max(fragments, (*tet_fragment)[t] + 1);
  }
  return fragments;
}

ContactSide projectile_side(Index projectile) { return {ContactSide::Kind::Projectile, projectile}; }

ContactSide static_side(Index obstacle) { return {ContactSide::Kind::Static, obstacle}; }

Vec3 side_velocity(const ContactSide& s, std::span<const CollisionBody> bodies,
                   std::span<const Projectile> projectiles) {
  switch (s.kind) {
    case ContactSide::Kind::Static: return Vec3::Zero();
    case ContactSide::Kind::Projectile: return projectiles[s.owner].velocity;
    case ContactSide::Kind::Embedded: {
      const CollisionBody& b = bodies[s.owner];
      return embedded_position(b.body->velocities(), b.body->elasticity().tets(), *b.points, s.point);
    }
  }
  return Vec3::Zero();
}

/// First contact of a point sweeping start → end with an axis-aligned box: the segment
/// against the box grown by the radius (slab test; a little conservative at the box's
/// edges and corners). Returns the contact normal and a point on the touched face.
std::optional<std::pair<Vec3, Vec3>> box_contact(const Box& box, const SweptPoint& p) {
  const Vec3 lo = box.min.array() - p.radius, hi = box.max.array() + p.radius;
  const Vec3 d = p.end - p.start;
  const bool starts_inside = (p.start.array() > lo.array()).all() && (p.start.array() < hi.array()).all();
  if (!starts_inside) {
    double enter = 0.0, leave = 1.0;
    int axis = -1;
    for (int k = 0; k < 3; ++k) {
      if (d[k] == 0.0) {
        if (p.start[k] <= lo[k] || p.start[k] >= hi[k]) return std::nullopt;
        continue;
      }
      double t0 = (lo[k] - p.start[k]) / d[k], t1 = (hi[k] - p.start[k]) / d[k];
      if (t0 > t1) std::swap(t0, t1);
      // `axis < 0 && t0 >= enter`: a point that starts exactly on the grown box's face
      // (where the previous step's contact left it) and moves in enters at s = 0.
      if (t0 > enter || (axis < 0 && t0 >= enter)) {
        enter = std::max(t0, 0.0);
        axis = k;
      }
      leave = std::min(leave, t1);
      if (enter > leave) return std::nullopt;
    }
    if (axis < 0) return std::nullopt;
    Vec3 normal = Vec3::Zero();
    normal[axis] = d[axis] > 0.0 ? -1.0 : 1.0;
    Vec3 anchor = p.start + enter * d;
    anchor[axis] = d[axis] > 0.0 ? box.min[axis] : box.max[axis];
    return std::pair{normal, anchor};
  }
  // Already touching at the start: push out through the nearest face of the grown box.
  const Vec3 q = p.end;
  int axis = 0;
  double best = std::numeric_limits<double>::infinity();
  bool towards_max = false;
  for (int k = 0; k < 3; ++k) {
    if (q[k] - lo[k] < best) {
      best = q[k] - lo[k];
      axis = k;
      towards_max = false;
    }
    if (hi[k] - q[k] < best) {
      best = hi[k] - q[k];
      axis = k;
      towards_max = true;
    }
  }
  if (best <= 0.0) return std::nullopt;  // moved out again during the step
  Vec3 normal = Vec3::Zero();
  normal[axis] = towards_max ? 1.0 : -1.0;
  Vec3 anchor = q;
  anchor[axis] = towards_max ? box.max[axis] : box.min[axis];
  return std::pair{normal, anchor};
}

/// Adds the contacts of one swept point (side `a`) with the static environment.
void static_contacts(const ContactSide& a, const SweptPoint& p, const ContactMaterial& material,
                     const Environment& environment, std::vector<Contact>& out, ContactCounts& counts) {
  if (environment.ground) {
    const Plane& g = *environment.ground;
    // A half space cannot be tunnelled through: the end state alone decides.
    const double height = g.normal.dot(p.end) - g.offset;
    if (height < p.radius) {
      const ContactMaterial m = combine(material, g.material);
      const double gap = g.normal.dot(p.start) - g.offset - p.radius;
      out.push_back({a, static_side(0), g.normal, p.radius, gap, m.restitution, m.friction});
    }
  }
  Index obstacle = 1;  // 0 is the ground
  for (const Box& box : environment.boxes) {
    ++obstacle;
    if (const auto hit = box_contact(box, p)) {
      const ContactMaterial m = combine(material, box.material);
      const double gap = hit->first.dot(p.start - hit->second) - p.radius;
      out.push_back({a, static_side(obstacle - 1), hit->first, p.radius, gap, m.restitution, m.friction});
      const Vec3 outside = p.end.cwiseMax(box.min).cwiseMin(box.max) - p.end;
      if (outside.norm() >= p.radius) ++counts.swept;
    }
  }
  for (const Ball& ball : environment.balls) {
    ++obstacle;
    const auto s = time_of_impact(p.start, p.end, ball.center, ball.center, p.radius + ball.radius);
    if (!s) continue;
    Vec3 normal = p.start + *s * (p.end - p.start) - ball.center;
    normal = normal.norm() > 0.0 ? Vec3(normal.normalized()) : Vec3(Vec3::UnitZ());
    const ContactMaterial m = combine(material, ball.material);
    const Vec3 anchor = ball.center + ball.radius * normal;
    out.push_back({a, static_side(obstacle - 1), normal, p.radius, normal.dot(p.start - anchor) - p.radius,
                   m.restitution, m.friction});
    if ((p.end - ball.center).norm() >= p.radius + ball.radius) ++counts.swept;
  }
}

/// Adds the contact between two swept points if they meet during the step. They touch
/// at `reach` (the sum of the radii unless a split left them overlapping).
void pair_contact(const ContactSide& a, const SweptPoint& pa, const ContactSide& b, const SweptPoint& pb,
                  const ContactMaterial& m, std::vector<Contact>& out, ContactCounts& counts, double reach) {
  const auto s = time_of_impact(pa.start, pa.end, pb.start, pb.end, reach);
  if (!s) return;
  Vec3 normal = (pa.start + *s * (pa.end - pa.start)) - (pb.start + *s * (pb.end - pb.start));
  if (!(normal.norm() > 0.0)) normal = pa.end - pb.end;
  normal = normal.norm() > 0.0 ? Vec3(normal.normalized()) : Vec3(Vec3::UnitZ());
  out.push_back({a, b, normal, reach, normal.dot(pa.start - pb.start) - reach, m.restitution, m.friction});
  if ((pa.end - pb.end).norm() >= reach) ++counts.swept;
}

}  // namespace

std::optional<double> time_of_impact(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1, double distance) {
  // |d0 + s (d1 − d0)|² = distance², the smallest root in [0, 1].
  const Vec3 d0 = a0 - b0, dd = (a1 - b1) - d0;
  const double c = d0.squaredNorm() - distance * distance;
  if (c <= 0.0) return 0.0;
  const double a = dd.squaredNorm(), half_b = d0.dot(dd);
  if (a == 0.0 || half_b >= 0.0) return std::nullopt;  // not approaching
  const double discriminant = half_b * half_b - a * c;
  if (discriminant < 0.0) return std::nullopt;
  const double s = (-half_b - std::sqrt(discriminant)) / a;
  if (s > 1.0) return std::nullopt;
  return std::max(s, 0.0);
}

ObstacleHit deepest_obstacle(const Vec3& point, double radius, const Environment& environment,
                             std::span<const Projectile> projectiles) {
  ObstacleHit hit;
  const auto consider = [&](double depth, ObstacleHit::Kind kind, std::size_t index) {
    if (depth > hit.depth) hit = {kind, static_cast<Index>(index), depth};
  };
  if (environment.ground) {
    consider(radius - (environment.ground->normal.dot(point) - environment.ground->offset), ObstacleHit::Kind::Ground, 0);
  }
  for (std::size_t k = 0; k < environment.boxes.size(); ++k) {
    const Box& box = environment.boxes[k];
    const Vec3 inside_distance = (point - box.min).cwiseMin(box.max - point);
    const double inner = inside_distance.minCoeff();
    const double gap = inner > 0.0 ? 0.0 : (point.cwiseMax(box.min).cwiseMin(box.max) - point).norm();
    consider(inner > 0.0 ? radius + inner : radius - gap, ObstacleHit::Kind::Box, k);
  }
  for (std::size_t k = 0; k < environment.balls.size(); ++k) {
    const Ball& ball = environment.balls[k];
    consider(radius + ball.radius - (point - ball.center).norm(), ObstacleHit::Kind::Ball, k);
  }
  for (std::size_t k = 0; k < projectiles.size(); ++k) {
    const Projectile& p = projectiles[k];
    if (p.launched) consider(radius + p.radius - (point - p.position).norm(), ObstacleHit::Kind::Projectile, k);
  }
  return hit;
}

namespace {

/// Each embedded point's motion over the step, per body, and each body's swept bounds.
void sweep_points(std::span<const CollisionBody> bodies, std::vector<std::vector<SweptPoint>>& sweeps,
                  std::vector<AlignedBox>& bounds) {
  sweeps.resize(bodies.size());
  bounds.assign(bodies.size(), AlignedBox{});
  for (std::size_t bi = 0; bi < bodies.size(); ++bi) {
    const CollisionBody& b = bodies[bi];
    const Matrix4Xu& tets = b.body->elasticity().tets();
    sweeps[bi].resize(b.points->size());
    for (std::size_t k = 0; k < b.points->size(); ++k) {
      sweeps[bi][k] = {embedded_position(*b.start_positions, tets, *b.points, k),
                       embedded_position(b.body->positions(), tets, *b.points, k), b.points->radius[k]};
      bounds[bi].add(sweeps[bi][k]);
    }
  }
}

/// Contacts of every body's points with the static environment and the projectiles,
/// and of the projectiles with the environment and each other.
void environment_and_projectile_contacts(std::span<const CollisionBody> bodies,
                                         const std::vector<std::vector<SweptPoint>>& sweeps,
                                         const std::vector<AlignedBox>& bounds, const Environment& environment,
                                         std::span<const Projectile> projectiles,
                                         const std::vector<SweptPoint>& projectile_sweep, std::vector<Contact>& contacts,
                                         ContactCounts& counts) {
  for (Index bi = 0; bi < bodies.size(); ++bi) {
    for (Index k = 0; k < sweeps[bi].size(); ++k) {
      static_contacts(embedded_side(bodies, bi, k), sweeps[bi][k], bodies[bi].material, environment, contacts, counts);
    }
    for (Index j = 0; j < projectiles.size(); ++j) {
      if (!projectiles[j].launched) continue;
      AlignedBox pb;
      pb.add(projectile_sweep[j]);
      if (!pb.overlaps(bounds[bi])) continue;
      const ContactMaterial m = combine(bodies[bi].material, projectiles[j].material);
      for (Index k = 0; k < sweeps[bi].size(); ++k) {
        pair_contact(embedded_side(bodies, bi, k), sweeps[bi][k], projectile_side(j), projectile_sweep[j], m, contacts,
                     counts, sweeps[bi][k].radius + projectile_sweep[j].radius);
      }
    }
  }
  for (Index j = 0; j < projectiles.size(); ++j) {
    if (!projectiles[j].launched) continue;
    static_contacts(projectile_side(j), projectile_sweep[j], projectiles[j].material, environment, contacts, counts);
    for (Index i = j + 1; i < projectiles.size(); ++i) {
      if (!projectiles[i].launched) continue;
      pair_contact(projectile_side(j), projectile_sweep[j], projectile_side(i), projectile_sweep[i],
                   combine(projectiles[j].material, projectiles[i].material), contacts, counts,
                   projectile_sweep[j].radius + projectile_sweep[i].radius);
    }
  }
}

/// Contacts between points of different fragments or bodies (broad_phase.h).
void self_contacts(std::span<const CollisionBody> bodies, const std::vector<std::vector<SweptPoint>>& sweeps,
                   std::vector<Contact>& contacts, ContactCounts& counts) {
  // One body in one piece has nothing to collide with itself: skip the broad phase.
  const bool several_pieces = bodies.size() > 1 || (!bodies.empty() && [&] {
    const auto& fragment = *bodies.front().tet_fragment;
    return std::any_of(fragment.begin(), fragment.end(), [](Index f) { return f != 0; });
  }());
  if (!several_pieces) return;
  std::vector<std::vector<Index>> piece(bodies.size());
  for (std::size_t bi = 0; bi < bodies.size(); ++bi) {
    const EmbeddedPoints& points = *bodies[bi].points;
    piece[bi].resize(points.size());
    for (std::size_t k = 0; k < points.size(); ++k) piece[bi][k] = (*bodies[bi].tet_fragment)[points.tet[k]];
    if (const std::vector<std::uint8_t>* only = bodies[bi].obstacles_only) {
      for (std::size_t k = 0; k < std::min(only->size(), points.size()); ++k) {
        if ((*only)[k]) piece[bi][k] = kInvalidIndex;
      }
    }
  }
  const std::vector<PointPair> pairs = self_collision_pairs(sweeps, piece);
  counts.pairs_tested = pairs.size();
  // Narrow phase in pair order (each pair is found once); the later point is side a.
  for (const auto& [bj, kj, bi, k] : pairs) {
    const SweptPoint &pa = sweeps[bi][k], &pb = sweeps[bj][kj];
    double reach = pa.radius + pb.radius;
    const SplitOverlaps* overlaps = bodies[bi].split_overlaps;
    if (bi == bj && overlaps != nullptr && is_split_overlap(*overlaps, k, kj)) {
      // Held where it is: no contact while the free motion does not bring it closer.
      const double apart = (pa.start - pb.start).norm();
      if ((pa.end - pb.end).norm() >= apart) continue;
      reach = std::min(reach, apart);
    }
    pair_contact(embedded_side(bodies, bi, k), pa, embedded_side(bodies, bj, kj), pb,
                 combine(bodies[bi].material, bodies[bj].material), contacts, counts, reach);
  }
}

ContactKey key(const Contact& c) {
  return ContactKey{static_cast<std::uint8_t>(c.a.kind), static_cast<std::uint8_t>(c.b.kind), c.a.owner, c.a.point,
                    c.b.owner, c.b.point};
}

}  // namespace

StepContacts::StepContacts(std::span<CollisionBody> bodies, const Environment& environment,
                           std::span<Projectile> projectiles, std::span<const Vec3> projectile_start,
                           const CollisionSettings& settings)
    : m_bodies(bodies), m_projectiles(projectiles), m_projectile_start(projectile_start), m_settings(settings) {
  std::vector<SweptPoint> projectile_sweep(projectiles.size());
  for (std::size_t j = 0; j < projectiles.size(); ++j) {
    projectile_sweep[j] = {projectile_start[j], projectiles[j].position, projectiles[j].radius};
  }
  std::vector<std::vector<SweptPoint>> sweeps;
  std::vector<AlignedBox> bounds;
  sweep_points(bodies, sweeps, bounds);
  std::vector<Contact> contacts;
  environment_and_projectile_contacts(bodies, sweeps, bounds, environment, projectiles, projectile_sweep, contacts,
                                      m_counts);
  if (settings.self_collision) self_contacts(bodies, sweeps, contacts, m_counts);
  m_counts.contacts = contacts.size();
  // What the response must meet for each contact, warm-started from the last step's impulses.
  m_constraints.reserve(contacts.size());
  for (const Contact& c : contacts) {
    const double approach = c.normal.dot(side_velocity(c.a, bodies, projectiles) - side_velocity(c.b, bodies, projectiles));
    double warm_start = 0.0;
    if (settings.impulses != nullptr) {
      const auto found = settings.impulses->find(key(c));
      if (found != settings.impulses->end()) warm_start = found->second;
    }
    const auto [inelastic, elastic] = contact_targets(c, approach, settings);
    m_counts.restituting += elastic > inelastic ? 1 : 0;
    m_approach.push_back(approach);
    m_inelastic_target.push_back(inelastic);
    m_elastic_target.push_back(elastic);
    m_keys.push_back(key(c));
    m_constraints.push_back({c.a, c.b, c.normal, elastic, c.friction, warm_start, c.reach});
  }
}

StepContacts::~StepContacts() = default;

ContactCounts StepContacts::respond(double restitution_share, int iterations) {
  const double h = m_settings.dt;
  for (std::size_t k = 0; k < m_constraints.size(); ++k) {
    ContactConstraint& c = m_constraints[k];
    // Exact at shares 0 and 1.
    const double target = (1.0 - restitution_share) * m_inelastic_target[k] + restitution_share * m_elastic_target[k];
    // Answering again: the last answer's impulse is the warm start, scaled as a lone
    // contact's would be (its impulse is proportional to the velocity change it asks for).
    const double asked = c.target - m_approach[k], now = target - m_approach[k];
    if (m_answered && asked > 0.0 && now > 0.0) c.impulse *= now / asked;
    c.target = target;
  }
  m_answered = true;
  ContactResponseSettings response;
  response.contacts = m_settings.contacts;
  if (iterations > 0) response.contacts.iterations = iterations;
  response.dt = h;
  response.sparse_blocks_from_start = m_settings.sparse_blocks_from_start;
  response.reference_speed = m_settings.gravity.norm() * h;
  const ContactResponseReport outcome = respond_to_contacts(m_bodies, m_projectiles, m_constraints, response);
  ContactCounts counts = m_counts;
  counts.response_iterations = outcome.cg_iterations;
  counts.response_sweeps = outcome.sweeps;
  counts.rigid_answers = static_cast<std::size_t>(outcome.rigid_answers);
  counts.responses = 1;
  counts.ran_long = outcome.ran_long;
  counts.swept_to_cap = outcome.swept_to_cap;
  // Answering again (EnergyGuard::keep_restitution_within) meets the same pile.
  m_settings.sparse_blocks_from_start = m_settings.sparse_blocks_from_start || outcome.ran_long;
  if (m_settings.impulses != nullptr) {
    m_settings.impulses->clear();
    for (std::size_t k = 0; k < m_constraints.size(); ++k) {
      if (m_constraints[k].impulse > 0.0) m_settings.impulses->emplace(m_keys[k], m_constraints[k].impulse);
    }
  }
  // The bodies moved with their corrected velocities; projectiles move likewise.
  for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
    if (m_projectiles[j].launched) m_projectiles[j].position = m_projectile_start[j] + h * m_projectiles[j].velocity;
  }
  return counts;
}

std::vector<Touch> StepContacts::touches() const {
  std::vector<Touch> out;
  out.reserve(m_constraints.size());
  for (std::size_t k = 0; k < m_constraints.size(); ++k) {
    const ContactConstraint& c = m_constraints[k];
    out.push_back({spin_side(c.a, m_bodies), spin_side(c.b, m_bodies), c.b.kind == ContactSide::Kind::Projectile,
                   -m_approach[k]});
  }
  return out;
}

namespace {

/// The material of a static obstacle (its key's owner).
const ContactMaterial& obstacle_material(Index owner, const Environment& environment) {
  if (owner == 0 && environment.ground) return environment.ground->material;
  const Index box = owner - 1;  // obstacles: 0 the ground, then the boxes, then the balls
  return box < environment.boxes.size() ? environment.boxes[box].material
                                        : environment.balls[box - environment.boxes.size()].material;
}

}  // namespace

std::size_t resist_rolling(std::span<CollisionBody> bodies, const Environment& environment,
                           const ContactImpulses& impulses) {
  // Pairs take √(μa μb): with no body resisting, no contact does (a scene pays nothing).
  if (std::none_of(bodies.begin(), bodies.end(), [](const CollisionBody& b) { return b.material.rolling_resistance > 0.0; })) {
    return 0;
  }
  constexpr auto kEmbedded = static_cast<std::uint8_t>(ContactSide::Kind::Embedded);
  // Only a fragment that rests on one of its spheres can roll or spin on it; one held at
  // several is held against turning by their lever arms, and resisting its spin as well
  // fought the contact response: a light bar pressed down by 10^4 m/s^2 sank 0.43 m
  // (its bound 0.1). Per fragment: its one touching sphere, or kInvalidIndex for several.
  std::map<std::pair<Index, Index>, Index> touching_sphere;
  const auto note = [&](Index body, Index point) {
    const SpinSide f = spin_side(embedded_side(bodies, body, point), bodies);
    const auto [it, added] = touching_sphere.emplace(std::pair{f.body, f.fragment}, point);
    if (!added && it->second != point) it->second = kInvalidIndex;
  };
  for (const auto& [key, impulse] : impulses) {
    if (key.kind_a == kEmbedded) note(key.owner_a, key.point_a);
    if (key.kind_b == kEmbedded) note(key.owner_b, key.point_b);
  }
  const auto rolls = [&](const SpinSide& f) {
    return f.body != kInvalidIndex && touching_sphere.at(std::pair{f.body, f.fragment}) != kInvalidIndex;
  };
  std::vector<RollingContact> rolling;
  for (const auto& [key, impulse] : impulses) {
    // The embedded side comes first. A projectile's contacts do not resist: what this
    // stands in for is a fragment's shape resting on something, and a 1000 m/s hit's
    // impulse then stopped a light bar's spin at once and sank it 0.43 m (its bound 0.1).
    if (key.kind_a != kEmbedded || key.kind_b == static_cast<std::uint8_t>(ContactSide::Kind::Projectile)) continue;
    const CollisionBody& a = bodies[key.owner_a];
    const ContactSide side_a = embedded_side(bodies, key.owner_a, key.point_a);
    double radius = a.points->radius[key.point_a];
    double mu = a.material.rolling_resistance;
    ContactSide side_b;
    if (key.kind_b == kEmbedded) {
      const CollisionBody& b = bodies[key.owner_b];
      side_b = embedded_side(bodies, key.owner_b, key.point_b);
      radius = 0.5 * (radius + b.points->radius[key.point_b]);  // two spheres roll on their mean radius
      mu = std::sqrt(mu * b.material.rolling_resistance);
    } else {
      mu = std::sqrt(mu * obstacle_material(key.owner_b, environment).rolling_resistance);
    }
    const double most = mu * radius * impulse;
    SpinSide a_spin = spin_side(side_a, bodies), b_spin = spin_side(side_b, bodies);
    if (!rolls(a_spin) && !rolls(b_spin)) continue;
    if (!rolls(a_spin)) a_spin = {};  // held by several: it counts as still here
    if (!rolls(b_spin)) b_spin = {};
    if (most > 0.0) rolling.push_back({a_spin, b_spin, most});
  }
  if (rolling.empty()) return 0;
  std::vector<std::vector<Index>> node_fragment(bodies.size());
  std::vector<SpinBody> spin_bodies;
  spin_bodies.reserve(bodies.size());
  for (std::size_t bi = 0; bi < bodies.size(); ++bi) {
    const CollisionBody& b = bodies[bi];
    const Index fragments = fragments_of_nodes(*b.body, b.tet_fragment, node_fragment[bi]);
    spin_bodies.push_back({&b.body->positions(), &b.body->velocities(), &b.body->node_masses(),
                           b.body->pinned_nodes(), node_fragment[bi], fragments});
  }
  const std::vector<Matrix3Xd> change = sim::resist_rolling(spin_bodies, rolling);
  for (std::size_t bi = 0; bi < bodies.size(); ++bi) {
    ImplicitIntegrator& body = *bodies[bi].body;
    Eigen::VectorXd delta = Eigen::VectorXd::Zero(body.system_size());
    for (Index n = 0; n < body.node_count(); ++n) {
      const Index row = body.system_row(n);
      if (row != kInvalidIndex) delta.segment<3>(row) = change[bi].col(n);
    }
    // Velocities only, before this step's contacts are found and answered, so the
    // response sees the spin change and its contacts hold. Applied after the response,
    // the change rotated a light bar's far end into the ground (0.44 m deep under
    // 10^4 m/s^2); moving the positions with it (x += h δ) turns on a line, which
    // stretched a fast-turning bar (×2.3 its energy at dt = 0.1 s).
    body.correct_velocities(delta, 0.0);
  }
  return rolling.size();
}

ContactCounts resolve_collisions(std::span<CollisionBody> bodies, const Environment& environment,
                                 std::span<Projectile> projectiles, std::span<const Vec3> projectile_start,
                                 const CollisionSettings& settings) {
  return StepContacts(bodies, environment, projectiles, projectile_start, settings).respond(1.0);
}

}  // namespace fissure::sim
