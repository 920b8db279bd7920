#include "player/sim/contacts/rigid_response.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include "player/sim/contacts/joint_system.h"
#include "player/sim/implicit_integrator.h"
#include "player/sim/rigid_rotation.h"

namespace fissure::sim::contact_detail {
namespace {

using Side = ContactSide::Kind;

/// Each fragment's nodes (after a split a node is in one fragment); one fragment 0
/// without fragments.
std::vector<std::vector<NodeIndex>> fragment_nodes(const CollisionBody& b) {
  const Matrix4Xu& tets = b.body->elasticity().tets();
  std::vector<Index> node_fragment(b.body->node_count(), 0);
  Index fragments = 1;
  if (b.tet_fragment != nullptr) {
    for (Eigen::Index t = 0; t < tets.cols(); ++t) {
      const Index f = (*b.tet_fragment)[t];
      for (int c = 0; c < 4; ++c) node_fragment[tets(c, t)] = f;
      fragments = std::max(fragments, f + 1);
    }
  }
  std::vector<std::vector<NodeIndex>> out(fragments);
  for (NodeIndex n = 0; n < node_fragment.size(); ++n) out[node_fragment[n]].push_back(n);
  return out;
}

/// Per fragment, whether it is small enough to move rigidly (one fragment without fragments).
std::vector<std::uint8_t> small_fragments_of(const CollisionBody& b, int below) {
  if (b.tet_fragment == nullptr) {
    return {static_cast<std::uint8_t>(b.body->elasticity().tet_count() < static_cast<std::size_t>(below))};
  }
  const std::vector<Index>& tet_fragment = *b.tet_fragment;
  const Index count = tet_fragment.empty() ? 0 : *std::max_element(tet_fragment.begin(), tet_fragment.end()) + 1;
  return small_fragments(tet_fragment, count, below);
}

Index fragment_of(const CollisionBody& b, TetIndex tet) { return b.tet_fragment == nullptr ? 0 : (*b.tet_fragment)[tet]; }

/// The fragment's motion as a rigid body's: mass, centre of mass, inertia about it, and
/// the rigid velocity (V, Ω) that carries its momentum and angular momentum.
struct RigidBody {
  double mass = 0;
  Vec3 centre = Vec3::Zero();
  Mat3 inertia = Mat3::Zero(), inverse_inertia = Mat3::Zero();
  Vec3 velocity = Vec3::Zero(), spin = Vec3::Zero();
  double kinetic = 0;  ///< of all its nodes' motion [J]

  [[nodiscard]] double rigid_kinetic() const {
    return 0.5 * mass * velocity.squaredNorm() + 0.5 * spin.dot(inertia * spin);
  }
};

RigidBody rigid_body_of(const ImplicitIntegrator& body, std::span<const NodeIndex> nodes) {
  RigidBody r;
  const Eigen::VectorXd& m = body.node_masses();
  for (const NodeIndex n : nodes) {
    r.mass += m[n];
    r.centre += m[n] * body.positions().col(n);
  }
  r.centre /= r.mass;
  Vec3 momentum = Vec3::Zero(), angular = Vec3::Zero();
  for (const NodeIndex n : nodes) {
    const Vec3 arm = body.positions().col(n) - r.centre;
    const Vec3 v = body.velocities().col(n);
    r.inertia += m[n] * (arm.squaredNorm() * Mat3::Identity() - arm * arm.transpose());
    momentum += m[n] * v;
    angular += m[n] * arm.cross(v);
    r.kinetic += 0.5 * m[n] * v.squaredNorm();
  }
  r.inverse_inertia = r.inertia.inverse();
  r.velocity = momentum / r.mass;
  r.spin = r.inverse_inertia * angular;
  return r;
}

/// Whether its inertia can be inverted: nodes on a line (or a flattened sliver) have
/// little or none about it, and would turn without bound.
bool turns_freely(const RigidBody& r) { return r.inertia.determinant() > 1e-9 * std::pow(r.inertia.trace(), 3); }

/// The point's velocity: an embedded point's from its tet's nodes; an obstacle's is 0.
Vec3 side_velocity(std::span<const CollisionBody> bodies, const ContactSide& s) {
  if (s.kind != Side::Embedded) return Vec3::Zero();
  const ImplicitIntegrator& body = *bodies[s.owner].body;
  Vec3 v = Vec3::Zero();
  for (int i = 0; i < 4; ++i) v += s.weight[i] * body.velocities().col(body.elasticity().tets()(i, s.tet));
  return v;
}

/// target − n · (v_a − v_b): what the contact asks of the response [m/s].
double required_of(std::span<const CollisionBody> bodies, const ContactConstraint& c) {
  return c.target - c.normal.dot(side_velocity(bodies, c.a) - side_velocity(bodies, c.b));
}

/// Whether the candidate is at rest (rigid_response.h), with `nodes` its free nodes.
/// A resting contact asks for about one step of gravity (`reference_speed`, |g| h): 0.16
/// m/s at h = 1/60 s, 0.98 at 0.1 s. So its contacts may ask for twice that where it is
/// more than the resting speed (contact_targets' resting speed is 2 |g| h too). Not the
/// sum of the two: at 1/240 s that answered the 10,024-tet bunny rigidly in 126 of 480
/// steps against 185, with 1.7× the conjugate gradients (one run each).
bool at_rest(std::span<const CollisionBody> bodies, Index body, std::span<const NodeIndex> nodes,
             std::span<const ContactConstraint> contacts, std::span<const std::size_t> mine,
             const ContactSettings& settings, double reference_speed) {
  const double asked = settings.rigid_asked_speed(reference_speed), speed = settings.rigid_resting_speed;
  for (const std::size_t k : mine) {
    if (std::abs(required_of(bodies, contacts[k])) > asked) return false;
  }
  const RigidBody r = rigid_body_of(*bodies[body].body, nodes);
  return turns_freely(r) && r.kinetic - r.rigid_kinetic() <= 0.5 * r.mass * speed * speed;
}

}  // namespace

std::vector<RestingFragment> resting_fragments(std::span<const CollisionBody> bodies,
                                               std::span<const ContactConstraint> contacts,
                                               const ContactSettings& settings, double reference_speed) {
  std::vector<RestingFragment> out;
  if (!(settings.rigid_resting_speed > 0.0) && settings.rigid_fragments_below <= 0) return out;
  // (body, fragment) → its contacts; a fragment a projectile touches is out (a hit, or
  // a ball resting on it, is answered deformably).
  std::map<std::pair<Index, Index>, std::vector<std::size_t>> candidates;
  std::map<std::pair<Index, Index>, bool> excluded;
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const ContactConstraint& c = contacts[k];
    for (const ContactSide* s : {&c.a, &c.b}) {
      if (s->kind != Side::Embedded) continue;
      const std::pair<Index, Index> key{s->owner, fragment_of(bodies[s->owner], s->tet)};
      candidates[key].push_back(k);
      const Side other = s == &c.a ? c.b.kind : c.a.kind;
      if (other == Side::Projectile) excluded[key] = true;
    }
  }
  // Each body's fragments' nodes, made once and only for a body with a candidate.
  std::vector<std::vector<std::vector<NodeIndex>>> nodes_of(bodies.size());
  std::vector<std::vector<std::uint8_t>> small_of(bodies.size());  // per body, each fragment small or not
  for (auto& [key, mine] : candidates) {
    const CollisionBody& b = bodies[key.first];
    if (nodes_of[key.first].empty()) nodes_of[key.first] = fragment_nodes(b);
    const std::vector<NodeIndex>& nodes = nodes_of[key.first][key.second];
    const auto pinned = [&] { return std::any_of(nodes.begin(), nodes.end(), [&](NodeIndex n) { return b.body->pinned(n); }); };
    if (settings.rigid_fragments_below > 0) {
      if (small_of[key.first].empty()) small_of[key.first] = small_fragments_of(b, settings.rigid_fragments_below);
      if (small_of[key.first][key.second] != 0) {
        if (!pinned() && turns_freely(rigid_body_of(*b.body, nodes))) {
          out.push_back({.body = key.first, .nodes = nodes, .small = true});
        }
        continue;
      }
    }
    if (!(settings.rigid_resting_speed > 0.0) || excluded.count(key) > 0) continue;
    if (nodes.size() <= static_cast<std::size_t>(settings.dense_fragment_nodes)) continue;
    if (pinned()) continue;
    if (!at_rest(bodies, key.first, nodes, contacts, mine, settings, reference_speed)) continue;
    out.push_back({.body = key.first, .nodes = nodes});
  }
  return out;
}

std::vector<RigidGroup> rigid_groups(std::span<const CollisionBody> bodies, std::span<const RestingFragment> resting,
                                     const JointSystem& system) {
  std::vector<RigidGroup> out;
  for (const RestingFragment& f : resting) {
    const Eigen::Index offset = system.body_offset(static_cast<std::size_t>(f.body));
    if (offset < 0) continue;
    const ImplicitIntegrator& body = *bodies[f.body].body;
    const RigidBody rigid = rigid_body_of(body, f.nodes);
    // The joint system's mass is the body's system's, m_scale M (mass damping), so that a
    // rigid δ carries exactly its impulses there too (JointSystem::apply).
    const double scale = body.system_mass_scale();
    RigidGroup group;
    group.small = f.small;
    group.mass = scale * rigid.mass;
    group.inverse_inertia = rigid.inverse_inertia / scale;
    group.rows.reserve(f.nodes.size());
    group.arms.reserve(f.nodes.size());
    for (const NodeIndex n : f.nodes) {
      group.rows.push_back(offset + static_cast<Eigen::Index>(body.system_row(n)));
      group.arms.push_back(body.positions().col(n) - rigid.centre);
    }
    out.push_back(std::move(group));
  }
  return out;
}

}  // namespace fissure::sim::contact_detail
