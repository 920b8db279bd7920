#include "player/sim/collision.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "player/sim/contact_response.h"

namespace fissure::sim {

namespace {

/// One side of a contact: a point embedded in a body, a projectile, or a fixed point
/// on a static obstacle.
struct Side {
  enum class Kind : std::uint8_t { Static, Embedded, Projectile } kind = Kind::Static;
  Index owner = 0;  ///< body or projectile index; for a static side, which obstacle (ContactKey)
  Index point = 0;  ///< embedded point index
  Vec3 anchor = Vec3::Zero();
};

struct Contact {
  Side a, b;
  Vec3 normal;             ///< from b towards a
  double reach = 0;        ///< a and b touch when normal · (a − b) = reach
  double gap = 0;          ///< normal · (a − b) − reach at the start of the step
  double restitution = 0, friction = 0;
};

ContactMaterial combine(const ContactMaterial& a, const ContactMaterial& b) {
  return {std::max(a.restitution, b.restitution), std::sqrt(a.friction * b.friction)};
}

/// The required normal relative velocity of a contact (Box2D's speculative contacts):
/// it may close its start-of-step gap during the step but not cross it, vₙ ≥ −gap / h.
/// An overlap left from earlier steps is pushed out at kPushOut of its depth per step,
/// but no faster than kMaxPushOutSpeed: the push-out is a real velocity that stays after
/// the overlap is gone, so uncapped it would grow as 1/h (a 6 mm overlap at h = 1e-5 s
/// threw fragments apart at 120 m/s). Box2D caps it the same way
/// (contactPushMaxVelocity). Restitution applies only above a resting speed, so resting
/// contact does not jitter.
double contact_target(const Contact& c, double approach, const CollisionSettings& settings) {
  constexpr double kPushOut = 0.2;
  constexpr double kMaxPushOutSpeed = 1.0;  // [m/s]
  const double h = settings.dt;
  const double resting_speed = 2.0 * settings.gravity.norm() * h;
  const double speculative = c.gap >= 0.0 ? -c.gap / h : std::min(-kPushOut * c.gap / h, kMaxPushOutSpeed);
  if (approach < -resting_speed && approach < speculative) return std::max(speculative, -c.restitution * approach);
  return speculative;
}

/// The response's view of a side: the embedded point's tet and weights.
ContactSide response_side(const Side& s, std::span<const CollisionBody> bodies) {
  switch (s.kind) {
    case Side::Kind::Static: return {};
    case Side::Kind::Projectile: return {ContactSide::Kind::Projectile, s.owner};
    case Side::Kind::Embedded: {
      const EmbeddedPoints& points = *bodies[s.owner].points;
      return {ContactSide::Kind::Embedded, s.owner, points.tet[s.point], points.barycentric[s.point]};
    }
  }
  return {};
}

Vec3 side_velocity(const Side& s, std::span<const CollisionBody> bodies, std::span<const Projectile> projectiles) {
  switch (s.kind) {
    case Side::Kind::Static: return Vec3::Zero();
    case Side::Kind::Projectile: return projectiles[s.owner].velocity;
    case Side::Kind::Embedded: {
      const CollisionBody& b = bodies[s.owner];
      return embedded_position(b.body->velocities(), b.body->elasticity().tets(), *b.points, s.point);
    }
  }
  return Vec3::Zero();
}

struct SweptPoint {
  Vec3 start, end;
  double radius;
};

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
void static_contacts(const Side& a, const SweptPoint& p, const ContactMaterial& material,
                     const Environment& environment, std::vector<Contact>& out, ContactCounts& counts) {
  if (environment.ground) {
    const Plane& g = *environment.ground;
    // A half space cannot be tunnelled through: the end state alone decides.
    const double height = g.normal.dot(p.end) - g.offset;
    if (height < p.radius) {
      const ContactMaterial m = combine(material, g.material);
      const double gap = g.normal.dot(p.start) - g.offset - p.radius;
      out.push_back({a, Side{.owner = 0, .anchor = p.end - height * g.normal}, g.normal, p.radius, gap, m.restitution, m.friction});
    }
  }
  Index obstacle = 1;  // 0 is the ground
  for (const Box& box : environment.boxes) {
    ++obstacle;
    if (const auto hit = box_contact(box, p)) {
      const ContactMaterial m = combine(material, box.material);
      const double gap = hit->first.dot(p.start - hit->second) - p.radius;
      out.push_back({a, Side{.owner = obstacle - 1, .anchor = hit->second}, hit->first, p.radius, gap, m.restitution, m.friction});
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
    out.push_back({a, Side{.owner = obstacle - 1, .anchor = anchor}, normal, p.radius, normal.dot(p.start - anchor) - p.radius, m.restitution,
                   m.friction});
    if ((p.end - ball.center).norm() >= p.radius + ball.radius) ++counts.swept;
  }
}

/// Adds the contact between two swept points if they meet during the step.
void pair_contact(const Side& a, const SweptPoint& pa, const Side& b, const SweptPoint& pb,
                  const ContactMaterial& m, std::vector<Contact>& out, ContactCounts& counts) {
  const double reach = pa.radius + pb.radius;
  const auto s = time_of_impact(pa.start, pa.end, pb.start, pb.end, reach);
  if (!s) return;
  Vec3 normal = (pa.start + *s * (pa.end - pa.start)) - (pb.start + *s * (pb.end - pb.start));
  if (!(normal.norm() > 0.0)) normal = pa.end - pb.end;
  normal = normal.norm() > 0.0 ? Vec3(normal.normalized()) : Vec3(Vec3::UnitZ());
  out.push_back({a, b, normal, reach, normal.dot(pa.start - pb.start) - reach, m.restitution, m.friction});
  if ((pa.end - pb.end).norm() >= reach) ++counts.swept;
}

struct AlignedBox {
  Vec3 min = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 max = Vec3::Constant(-std::numeric_limits<double>::infinity());
  void add(const SweptPoint& p) {
    min = min.cwiseMin(Vec3(p.start.cwiseMin(p.end).array() - p.radius));
    max = max.cwiseMax(Vec3(p.start.cwiseMax(p.end).array() + p.radius));
  }
  [[nodiscard]] bool overlaps(const AlignedBox& o) const {
    return (min.array() <= o.max.array()).all() && (o.min.array() <= max.array()).all();
  }
};

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

double penetration(const Vec3& point, double radius, const Environment& environment,
                   std::span<const Projectile> projectiles) {
  double depth = 0.0;
  if (environment.ground) {
    depth = std::max(depth, radius - (environment.ground->normal.dot(point) - environment.ground->offset));
  }
  for (const Box& box : environment.boxes) {
    const Vec3 inside_distance = (point - box.min).cwiseMin(box.max - point);
    const double inner = inside_distance.minCoeff();
    if (inner > 0.0) {
      depth = std::max(depth, radius + inner);
    } else {
      const double gap = (point.cwiseMax(box.min).cwiseMin(box.max) - point).norm();
      depth = std::max(depth, radius - gap);
    }
  }
  for (const Ball& ball : environment.balls) {
    depth = std::max(depth, radius + ball.radius - (point - ball.center).norm());
  }
  for (const Projectile& p : projectiles) {
    if (p.launched) depth = std::max(depth, radius + p.radius - (point - p.position).norm());
  }
  return depth;
}

ContactCounts resolve_collisions(std::span<CollisionBody> bodies, const Environment& environment,
                                 std::span<Projectile> projectiles, std::span<const Vec3> projectile_start,
                                 const CollisionSettings& settings) {
  ContactCounts counts;
  const double h = settings.dt;
  std::vector<SweptPoint> projectile_sweep(projectiles.size());
  for (std::size_t j = 0; j < projectiles.size(); ++j) {
    projectile_sweep[j] = {projectile_start[j], projectiles[j].position, projectiles[j].radius};
  }
  // Every embedded point's motion over the step, and each body's swept bounds.
  std::vector<std::vector<SweptPoint>> sweeps(bodies.size());
  std::vector<AlignedBox> bounds(bodies.size());
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
  std::vector<Contact> contacts;
  for (std::size_t bi = 0; bi < bodies.size(); ++bi) {
    for (std::size_t k = 0; k < sweeps[bi].size(); ++k) {
      const Side a{Side::Kind::Embedded, static_cast<Index>(bi), static_cast<Index>(k)};
      static_contacts(a, sweeps[bi][k], bodies[bi].material, environment, contacts, counts);
    }
    for (std::size_t j = 0; j < projectiles.size(); ++j) {
      if (!projectiles[j].launched) continue;
      AlignedBox pb;
      pb.add(projectile_sweep[j]);
      if (!pb.overlaps(bounds[bi])) continue;
      const Side b{Side::Kind::Projectile, static_cast<Index>(j)};
      const ContactMaterial m = combine(bodies[bi].material, projectiles[j].material);
      for (std::size_t k = 0; k < sweeps[bi].size(); ++k) {
        const Side a{Side::Kind::Embedded, static_cast<Index>(bi), static_cast<Index>(k)};
        pair_contact(a, sweeps[bi][k], b, projectile_sweep[j], m, contacts, counts);
      }
    }
  }
  for (std::size_t j = 0; j < projectiles.size(); ++j) {
    if (!projectiles[j].launched) continue;
    const Side a{Side::Kind::Projectile, static_cast<Index>(j)};
    static_contacts(a, projectile_sweep[j], projectiles[j].material, environment, contacts, counts);
    for (std::size_t i = j + 1; i < projectiles.size(); ++i) {
      if (!projectiles[i].launched) continue;
      const Side b{Side::Kind::Projectile, static_cast<Index>(i)};
      pair_contact(a, projectile_sweep[j], b, projectile_sweep[i], combine(projectiles[j].material, projectiles[i].material),
                   contacts, counts);
    }
  }
  // One body in one piece has nothing to collide with itself: skip the broad phase.
  const bool several_pieces = bodies.size() > 1 || (!bodies.empty() && [&] {
    const auto& fragment = *bodies.front().tet_fragment;
    return std::any_of(fragment.begin(), fragment.end(), [](Index f) { return f != 0; });
  }());
  if (settings.self_collision && several_pieces) {
    // Sort and sweep over the swept bounds of the points that can meet another piece.
    // (A spatial hash sized by the radius broke down with fine spheres: fast fragments'
    // swept boxes spanned thousands of cells, and 18k spheres took 0.5 s a step.)
    // 1. Each piece's bounds: a point matters only where it overlaps another piece's.
    struct Piece {
      Index body, fragment;
      bool operator<(const Piece& o) const { return std::tie(body, fragment) < std::tie(o.body, o.fragment); }
    };
    const auto piece_of = [&](Index bi, Index k) {
      return Piece{bi, (*bodies[bi].tet_fragment)[bodies[bi].points->tet[k]]};
    };
    // A blown-up point (non-finite position) cannot be placed, so it meets nothing.
    const auto placeable = [&](Index bi, Index k) {
      const SweptPoint& p = sweeps[bi][k];
      return p.radius > 0.0 && p.start.allFinite() && p.end.allFinite();
    };
    std::map<Piece, AlignedBox> piece_bounds;
    for (Index bi = 0; bi < bodies.size(); ++bi) {
      for (Index k = 0; k < sweeps[bi].size(); ++k) {
        if (placeable(bi, k)) piece_bounds[piece_of(bi, k)].add(sweeps[bi][k]);
      }
    }
    const std::vector<std::pair<Piece, AlignedBox>> pieces(piece_bounds.begin(), piece_bounds.end());
    // Past this many pieces (a shattered body) the per-point filter would cost more than
    // it saves: every point goes to the sweep.
    constexpr std::size_t kMaxFilteredPieces = 64;
    const bool filter = pieces.size() <= kMaxFilteredPieces;
    struct Candidate {
      AlignedBox box;
      Index body, point, piece;  // piece: index into `pieces`
    };
    std::vector<Candidate> candidates;
    for (Index bi = 0; bi < bodies.size(); ++bi) {
      for (Index k = 0; k < sweeps[bi].size(); ++k) {
        if (!placeable(bi, k)) continue;
        Candidate c{{}, bi, k, 0};
        c.box.add(sweeps[bi][k]);
        const Piece piece = piece_of(bi, k);
        c.piece = static_cast<Index>(
            std::lower_bound(pieces.begin(), pieces.end(), piece, [](const auto& e, const Piece& p) { return e.first < p; }) -
            pieces.begin());
        const bool near_another = !filter || std::any_of(pieces.begin(), pieces.end(), [&](const auto& other) {
          return &other != &pieces[c.piece] && c.box.overlaps(other.second);
        });
        if (near_another) candidates.push_back(c);
      }
    }
    // 2. Sweep along the axis where the candidates spread most; ties in a fixed order,
    // so the pairs (and the contacts) do not depend on anything but the state.
    AlignedBox extent;
    for (const Candidate& c : candidates) {
      extent.min = extent.min.cwiseMin(c.box.min);
      extent.max = extent.max.cwiseMax(c.box.max);
    }
    int axis = 0;
    if (!candidates.empty()) (extent.max - extent.min).maxCoeff(&axis);
    std::sort(candidates.begin(), candidates.end(), [axis](const Candidate& x, const Candidate& y) {
      return std::tie(x.box.min[axis], x.body, x.point) < std::tie(y.box.min[axis], y.body, y.point);
    });
    std::vector<std::tuple<Index, Index, Index, Index>> pairs;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      const Candidate& ci = candidates[i];
      for (std::size_t j = i + 1; j < candidates.size() && candidates[j].box.min[axis] <= ci.box.max[axis]; ++j) {
        const Candidate& cj = candidates[j];
        if (cj.piece == ci.piece || !ci.box.overlaps(cj.box)) continue;
        // (earlier point, later point) in (body, index) order, as the narrow phase expects.
        if (std::pair{ci.body, ci.point} < std::pair{cj.body, cj.point}) {
          pairs.emplace_back(ci.body, ci.point, cj.body, cj.point);
        } else {
          pairs.emplace_back(cj.body, cj.point, ci.body, ci.point);
        }
      }
    }
    // 3. Narrow phase in pair order (each pair is found once).
    std::sort(pairs.begin(), pairs.end());
    counts.pairs_tested = pairs.size();
    for (const auto& [bj, kj, bi, k] : pairs) {
      const Side a{Side::Kind::Embedded, bi, k}, b{Side::Kind::Embedded, bj, kj};
      pair_contact(a, sweeps[bi][k], b, sweeps[bj][kj], combine(bodies[bi].material, bodies[bj].material), contacts,
                   counts);
    }
  }
  counts.contacts = contacts.size();
  std::vector<ContactConstraint> constraints;
  constraints.reserve(contacts.size());
  const auto key = [](const Contact& c) {
    return ContactKey{static_cast<std::uint8_t>(c.a.kind), static_cast<std::uint8_t>(c.b.kind), c.a.owner, c.a.point,
                      c.b.owner, c.b.point};
  };
  for (const Contact& c : contacts) {
    const double approach = c.normal.dot(side_velocity(c.a, bodies, projectiles) - side_velocity(c.b, bodies, projectiles));
    double warm_start = 0.0;
    if (settings.impulses != nullptr) {
      const auto found = settings.impulses->find(key(c));
      if (found != settings.impulses->end()) warm_start = found->second;
    }
    constraints.push_back({response_side(c.a, bodies), response_side(c.b, bodies), c.normal,
                           contact_target(c, approach, settings), c.friction, warm_start});
  }
  ContactResponseSettings response;
  response.dt = h;
  response.iterations = settings.iterations;
  response.reference_speed = settings.gravity.norm() * h;
  const ContactResponseReport outcome = respond_to_contacts(bodies, projectiles, constraints, response);
  counts.response_iterations = outcome.cg_iterations;
  if (settings.impulses != nullptr) {
    settings.impulses->clear();
    for (std::size_t k = 0; k < contacts.size(); ++k) {
      if (constraints[k].impulse > 0.0) settings.impulses->emplace(key(contacts[k]), constraints[k].impulse);
    }
  }
  // The bodies moved with their corrected velocities; projectiles move likewise.
  for (std::size_t j = 0; j < projectiles.size(); ++j) {
    if (projectiles[j].launched) projectiles[j].position = projectile_sweep[j].start + h * projectiles[j].velocity;
  }
  return counts;
}

}  // namespace fissure::sim
