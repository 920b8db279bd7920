#include "player/sim/contacts/rigid_response.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include "player/sim/implicit_integrator.h"

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

/// The body's side of a contact: +1 if it is side a (the normal points towards it), −1 if b.
double body_sign(const ContactConstraint& c) { return c.a.kind == Side::Embedded ? 1.0 : -1.0; }
const ContactSide& body_side(const ContactConstraint& c) { return c.a.kind == Side::Embedded ? c.a : c.b; }

/// The embedded point's position and velocity.
std::pair<Vec3, Vec3> point_state(const ImplicitIntegrator& body, const ContactSide& s) {
  Vec3 x = Vec3::Zero(), v = Vec3::Zero();
  for (int i = 0; i < 4; ++i) {
    const NodeIndex n = body.elasticity().tets()(i, s.tet);
    x += s.weight[i] * body.positions().col(n);
    v += s.weight[i] * body.velocities().col(n);
  }
  return {x, v};
}

/// target − n · (v_a − v_b): what the contact asks of the response [m/s].
double required_of(const ImplicitIntegrator& body, const ContactConstraint& c) {
  return c.target - c.normal.dot(body_sign(c) * point_state(body, body_side(c)).second);
}

Mat3 cross_matrix(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

/// Whether the candidate is at rest (rigid_response.h), with `nodes` its free nodes.
/// A resting contact asks for about one step of gravity (`reference_speed`, |g| h): 0.16
/// m/s at h = 1/60 s, 0.98 at 0.1 s. So its contacts may ask for twice that where it is
/// more than the resting speed (contact_targets' resting speed is 2 |g| h too). Not the
/// sum of the two: at 1/240 s that answered the 10,024-tet bunny rigidly in 126 of 480
/// steps against 185, with 1.7× the conjugate gradients (one run each).
bool at_rest(const ImplicitIntegrator& body, std::span<const NodeIndex> nodes, std::span<const ContactConstraint> contacts,
             std::span<const std::size_t> mine, double speed, double reference_speed) {
  const double asked = std::max(speed, 2.0 * reference_speed);
  for (const std::size_t k : mine) {
    if (std::abs(required_of(body, contacts[k])) > asked) return false;
  }
  const RigidBody r = rigid_body_of(body, nodes);
  // Nodes on a line have no inertia about it (never a fragment of tets with volume).
  if (!(r.inertia.determinant() > 1e-9 * std::pow(r.inertia.trace(), 3))) return false;
  return r.kinetic - r.rigid_kinetic() <= 0.5 * r.mass * speed * speed;
}

/// One contact of the rigid answer, in its frame F (normal, two tangents).
struct RigidContact {
  Mat3 frame;
  Vec3 arm;            ///< from the centre of mass to the embedded point
  Mat3 delassus;       ///< Fᵀ (I/m − [r]× I⁻¹ [r]×) F: the point's answer to a unit impulse
  Eigen::Matrix2d tangent_inverse;
  Vec3 free_velocity;  ///< Fᵀ (v_a − v_b) before the answer
  double required = 0, friction = 0, tolerance = 0, acceptable = 0;
  Vec3 impulse = Vec3::Zero();  ///< on side a, in the frame
};

/// The sweeps' state: the rigid correction (V, Ω) the impulses so far make.
class RigidSweeps {
 public:
  RigidSweeps(const RigidBody& rigid, std::vector<RigidContact> contacts, double sign)
      : m_rigid(rigid), m_contacts(std::move(contacts)), m_sign(sign) {
    for (RigidContact& c : m_contacts) move(c, c.impulse);
  }

  void sweep() {
    for (RigidContact& c : m_contacts) solve(c);
  }

  struct Violation {
    bool short_of_target = false, overshoots = false, unacceptable = false;
  };
  [[nodiscard]] Violation violation() const {
    Violation v;
    for (const RigidContact& c : m_contacts) {
      const double shortfall = c.required - change_at(c)[0];
      v.short_of_target = v.short_of_target || shortfall > c.tolerance;
      v.overshoots = v.overshoots || (c.impulse[0] > 0.0 && -shortfall > c.tolerance);
      v.unacceptable = v.unacceptable || shortfall > c.acceptable;
    }
    return v;
  }
  [[nodiscard]] const std::vector<RigidContact>& contacts() const { return m_contacts; }
  [[nodiscard]] const Vec3& velocity_change() const { return m_velocity; }
  [[nodiscard]] const Vec3& spin_change() const { return m_spin; }

 private:
  /// Fᵀ (v_a − v_b) added so far at the contact.
  [[nodiscard]] Vec3 change_at(const RigidContact& c) const {
    return c.frame.transpose() * (m_sign * (m_velocity + m_spin.cross(c.arm)));
  }
  /// The body takes ± F change on side a's impulse.
  void move(const RigidContact& c, const Vec3& change) {
    const Vec3 impulse = m_sign * (c.frame * change);
    m_velocity += impulse / m_rigid.mass;
    m_spin += m_rigid.inverse_inertia * c.arm.cross(impulse);
  }
  void solve(RigidContact& c) {
    Vec3 relative = change_at(c);
    const Vec3 before = c.impulse;
    c.impulse[0] = std::max(0.0, c.impulse[0] + (c.required - relative[0]) / c.delassus(0, 0));
    relative += c.delassus.col(0) * (c.impulse[0] - before[0]);
    if (c.friction > 0.0) {
      const Eigen::Vector2d sliding = c.free_velocity.tail<2>() + relative.tail<2>();
      Eigen::Vector2d tangential = c.impulse.tail<2>() - c.tangent_inverse * sliding;
      const double cone = c.friction * c.impulse[0], size = tangential.norm();
      if (size > cone) tangential *= cone / size;
      c.impulse.tail<2>() = tangential;
    }
    move(c, c.impulse - before);
  }

  const RigidBody& m_rigid;
  std::vector<RigidContact> m_contacts;
  double m_sign;
  Vec3 m_velocity = Vec3::Zero(), m_spin = Vec3::Zero();
};

RigidContact rigid_contact(const ImplicitIntegrator& body, const RigidBody& rigid, const ContactConstraint& c,
                           const ContactSettings& settings, double dt, double reference_speed) {
  RigidContact out;
  out.frame = contact_frame(c.normal);
  const auto [point, velocity] = point_state(body, body_side(c));
  out.arm = point - rigid.centre;
  const Mat3 arm = cross_matrix(out.arm);
  const Mat3 compliance = Mat3::Identity() / rigid.mass - arm * rigid.inverse_inertia * arm;
  out.delassus = out.frame.transpose() * compliance * out.frame;
  const Eigen::Matrix2d tangent = out.delassus.bottomRightCorner<2, 2>();
  out.tangent_inverse = tangent.determinant() > 0.0 ? Eigen::Matrix2d(tangent.inverse()) : Eigen::Matrix2d::Zero();
  out.free_velocity = out.frame.transpose() * (body_sign(c) * velocity);
  out.required = c.target - out.free_velocity[0];
  out.friction = c.friction;
  // The augmented Lagrangian's rule, and never more than the debris' share of the reach
  // per step (answer_debris in contact_response.cpp).
  const double allowed = settings.allowed_miss(out.required, c.reach, dt, reference_speed);
  out.acceptable = settings.acceptable_sweep_miss(allowed, c.reach, dt);
  out.tolerance = std::min(allowed, out.acceptable);
  out.impulse = Vec3(std::max(c.impulse, 0.0), 0.0, 0.0);
  return out;
}

}  // namespace

std::vector<RestingFragment> resting_fragments(std::span<const CollisionBody> bodies,
                                               std::span<const ContactConstraint> contacts,
                                               const ContactSettings& settings, double reference_speed) {
  std::vector<RestingFragment> out;
  if (!(settings.rigid_resting_speed > 0.0)) return out;
  // (body, fragment) → its contacts; a fragment touched by anything but a static
  // obstacle is out.
  std::map<std::pair<Index, Index>, std::vector<std::size_t>> candidates;
  std::map<std::pair<Index, Index>, bool> excluded;
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const ContactConstraint& c = contacts[k];
    for (const ContactSide* s : {&c.a, &c.b}) {
      if (s->kind != Side::Embedded) continue;
      const std::pair<Index, Index> key{s->owner, fragment_of(bodies[s->owner], s->tet)};
      candidates[key].push_back(k);
      const Side other = s == &c.a ? c.b.kind : c.a.kind;
      if (other != Side::Static) excluded[key] = true;
    }
  }
  // Each body's fragments' nodes, made once and only for a body with a candidate.
  std::vector<std::vector<std::vector<NodeIndex>>> nodes_of(bodies.size());
  for (auto& [key, mine] : candidates) {
    if (excluded.count(key) > 0) continue;
    const CollisionBody& b = bodies[key.first];
    if (nodes_of[key.first].empty()) nodes_of[key.first] = fragment_nodes(b);
    const std::vector<NodeIndex>& nodes = nodes_of[key.first][key.second];
    if (nodes.size() <= static_cast<std::size_t>(settings.dense_fragment_nodes)) continue;
    if (std::any_of(nodes.begin(), nodes.end(), [&](NodeIndex n) { return b.body->pinned(n); })) continue;
    RestingFragment f{.body = key.first, .nodes = nodes, .contacts = std::move(mine)};
    if (!at_rest(*b.body, f.nodes, contacts, f.contacts, settings.rigid_resting_speed, reference_speed)) continue;
    out.push_back(std::move(f));
  }
  return out;
}

RigidAnswer answer_as_rigid(const RestingFragment& fragment, CollisionBody& body,
                            std::span<ContactConstraint> contacts, const ContactSettings& settings, double dt,
                            double reference_speed) {
  ImplicitIntegrator& integrator = *body.body;
  const RigidBody rigid = rigid_body_of(integrator, fragment.nodes);
  std::vector<RigidContact> rows;
  rows.reserve(fragment.contacts.size());
  bool any_friction = false;
  for (const std::size_t k : fragment.contacts) {
    rows.push_back(rigid_contact(integrator, rigid, contacts[k], settings, dt, reference_speed));
    any_friction = any_friction || contacts[k].friction > 0.0;
  }
  // Every contact is with a static obstacle, so the body is on the same side of each:
  // the sign of the first holds for all.
  const double sign = body_sign(contacts[fragment.contacts.front()]);
  RigidSweeps sweeps(rigid, std::move(rows), sign);
  RigidAnswer answer;
  for (int s = 0; s < settings.sequential_impulse_sweeps; ++s) {
    sweeps.sweep();
    ++answer.sweeps;
    const RigidSweeps::Violation v = sweeps.violation();
    answer.acceptable = !v.unacceptable;
    if (!v.short_of_target && !v.overshoots && (!any_friction || s >= 1)) break;
  }
  if (!answer.acceptable) return answer;
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(integrator.system_size());
  for (const NodeIndex n : fragment.nodes) {
    const Vec3 arm = integrator.positions().col(n) - rigid.centre;
    delta.segment<3>(integrator.system_row(n)) = sweeps.velocity_change() + sweeps.spin_change().cross(arm);
  }
  integrator.correct_velocities(delta, dt);
  for (std::size_t i = 0; i < fragment.contacts.size(); ++i) {
    contacts[fragment.contacts[i]].impulse = sweeps.contacts()[i].impulse[0];
  }
  return answer;
}

}  // namespace fissure::sim::contact_detail
