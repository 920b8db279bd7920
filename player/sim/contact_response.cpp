#include "player/sim/contact_response.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "player/sim/conjugate_gradient.h"

namespace fissure::sim {

namespace {

/// κ_k = kPenaltyRatio / Σᵢ bᵢ² / (nᵀ Aᵢᵢ n), the point's inverse mass as the system's
/// diagonal sees it. Not the lumped mass: where h²K dominates (light surface nodes, stiff
/// materials) a point answers an impulse 50× less than its mass says, and κ from the
/// mass took 8 iterations to meet half of a single contact's target. For one node
/// (A⁻¹)ᵢᵢ ≥ 1 / Aᵢᵢ, so each iteration leaves at most 1 / (1 + kPenaltyRatio) of its
/// shortfall (below the cap that follows). Larger ratios do fewer outer iterations but make the inner solves harder,
/// which their preconditioners (the bodies' own) do not see. Measured on the bunny scene
/// (480 steps, inner tolerance 1e-3): ratio 1 took 26 CG iterations per response and 2
/// took 36 (4 and 16 took 43 and 57 before a fix to the stopping rule); penetration did
/// not improve above 1.
constexpr double kPenaltyRatio = 1.0;
/// ... but the diagonal counts for at most this many times the lumped mass: κ far above
/// the mass makes any residual the inner solve leaves in a body's rigid motion (where A
/// is only M) a velocity error Aᵢᵢ / mᵢ times larger. Uncapped, E = 1e11 at dt = 0.1
/// (Aᵢᵢ / mᵢ ~ 1e8) ran away to 1e35 J in the stability grid. With the cap at 1, 4 or 16
/// the grid holds; the bunny scene's render-vertex penetration is 2.4, 1.5 and 0.8 mm.
constexpr double kMaxStiffnessShare = 16.0;
/// Sliding slower than this counts as sticking: the friction damping is capped at
/// μ λ / kStickSpeed, and in any case at kFrictionPenaltyRatio κ, for conditioning.
constexpr double kStickSpeed = 1e-3;  // [m/s]
constexpr double kFrictionPenaltyRatio = 4.0;

/// G x = Σ weight · x.segment<3>(row): one side's point velocity, signed (b negative).
struct Entry {
  Eigen::Index row;
  double weight;
};

struct Row {
  std::array<Entry, 8> entries{};
  int count = 0;
  Vec3 normal;
  Vec3 free_velocity;  ///< relative velocity v_a − v_b before the response
  double required = 0; ///< r = target − n · free_velocity: what δ must add along n
  double kappa = 0;
  double friction = 0;
  double lambda = 0;
  double eta = 0;      ///< friction damping of this outer iteration [kg]
  bool active = false;

  [[nodiscard]] Vec3 apply(const Eigen::VectorXd& x) const {
    Vec3 g = Vec3::Zero();
    for (int e = 0; e < count; ++e) g += entries[e].weight * x.segment<3>(entries[e].row);
    return g;
  }
  void scatter(const Vec3& f, Eigen::VectorXd& y) const {
    for (int e = 0; e < count; ++e) y.segment<3>(entries[e].row) += entries[e].weight * f;
  }
  /// The force this contact exerts for a correction with relative velocity change g.
  [[nodiscard]] Vec3 force(const Vec3& g, double normal_impulse) const {
    const Vec3 sliding = free_velocity + g;
    return normal_impulse * normal - eta * (sliding - normal.dot(sliding) * normal);
  }
};

class JointSystem {
 public:
  JointSystem(std::span<CollisionBody> bodies, std::span<Projectile> projectiles,
              std::span<const ContactConstraint> contacts)
      : m_bodies(bodies), m_projectiles(projectiles) {
    m_body_offset.assign(bodies.size(), -1);
    m_projectile_offset.assign(projectiles.size(), -1);
    const auto touch = [&](const ContactSide& s) {
      if (s.kind == ContactSide::Kind::Embedded && m_body_offset[s.owner] < 0) m_body_offset[s.owner] = 0;
      if (s.kind == ContactSide::Kind::Projectile && m_projectile_offset[s.owner] < 0) m_projectile_offset[s.owner] = 0;
    };
    for (const ContactConstraint& c : contacts) {
      touch(c.a);
      touch(c.b);
    }
    // Rows in a fixed order (bodies, then projectiles), whatever the contact order.
    for (std::size_t bi = 0; bi < bodies.size(); ++bi) {
      // A body pinned whole cannot move: it stays out, like a static obstacle.
      if (m_body_offset[bi] < 0 || bodies[bi].body->system_size() == 0) {
        m_body_offset[bi] = -1;
        continue;
      }
      m_body_offset[bi] = m_size;
      m_size += bodies[bi].body->system_size();
    }
    for (std::size_t j = 0; j < projectiles.size(); ++j) {
      if (m_projectile_offset[j] < 0) continue;
      m_projectile_offset[j] = m_size;
      m_size += 3;
    }
    m_rows.reserve(contacts.size());
    m_contact_row.assign(contacts.size(), kInvalidIndex);
    for (std::size_t k = 0; k < contacts.size(); ++k) {
      Row row;
      row.normal = contacts[k].normal;
      row.friction = contacts[k].friction;
      double inverse_mass = add_side(contacts[k].a, 1.0, row);
      inverse_mass += add_side(contacts[k].b, -1.0, row);
      if (row.count == 0 || !(inverse_mass > 0.0)) continue;  // nothing here can move
      row.free_velocity = velocity(contacts[k].a) - velocity(contacts[k].b);
      row.required = contacts[k].target - row.normal.dot(row.free_velocity);
      row.kappa = kPenaltyRatio / inverse_mass;
      row.lambda = std::max(contacts[k].impulse, 0.0);
      m_contact_row[k] = static_cast<Index>(m_rows.size());
      m_rows.push_back(row);
    }
  }

  [[nodiscard]] Eigen::Index size() const { return m_size; }
  std::vector<Row>& rows() { return m_rows; }
  [[nodiscard]] Index row_of(std::size_t contact) const { return m_contact_row[contact]; }

  /// y = (𝒜 + Σ_active κ n nᵀ ⊗ G + Σ η Gᵀ T G) x.
  void multiply(const Eigen::VectorXd& x, Eigen::VectorXd& y) {
    y.resize(x.size());
    for_each_body_block(x, y, &ImplicitIntegrator::multiply_system);
    for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
      if (m_projectile_offset[j] >= 0) {
        y.segment<3>(m_projectile_offset[j]) = m_projectiles[j].mass * x.segment<3>(m_projectile_offset[j]);
      }
    }
    for (const Row& row : m_rows) {
      const Vec3 g = row.apply(x);
      const double gn = row.normal.dot(g);
      Vec3 f = row.eta * (g - gn * row.normal);
      if (row.active) f += row.kappa * gn * row.normal;
      row.scatter(f, y);
    }
  }

  /// The bodies' own preconditioners; each projectile's 3×3 block exactly.
  void precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z) {
    z.resize(r.size());
    for_each_body_block(r, z, &ImplicitIntegrator::precondition_system);
    for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
      if (m_projectile_offset[j] >= 0) {
        z.segment<3>(m_projectile_offset[j]) = m_projectile_block[j].solve(r.segment<3>(m_projectile_offset[j]));
      }
    }
  }

  /// Each projectile's block of the current operator (mass plus its contacts' terms).
  void update_projectile_blocks() {
    m_projectile_block.resize(m_projectiles.size());
    std::vector<Mat3> block(m_projectiles.size(), Mat3::Zero());
    for (std::size_t j = 0; j < m_projectiles.size(); ++j) block[j] = m_projectiles[j].mass * Mat3::Identity();
    for (const Row& row : m_rows) {
      const Mat3 nn = row.normal * row.normal.transpose();
      const Mat3 term = row.eta * (Mat3::Identity() - nn) + (row.active ? row.kappa : 0.0) * nn;
      for (int e = 0; e < row.count; ++e) {
        for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
          if (row.entries[e].row == m_projectile_offset[j]) block[j] += row.entries[e].weight * row.entries[e].weight * term;
        }
      }
    }
    for (std::size_t j = 0; j < m_projectiles.size(); ++j) m_projectile_block[j].compute(block[j]);
  }

  /// Applies the correction: bodies move by it (rigidly shifted so each gains exactly
  /// the impulses it received), projectiles take exactly their impulses.
  void apply(const Eigen::VectorXd& delta, const std::vector<Vec3>& forces, double h) {
    Eigen::VectorXd net = Eigen::VectorXd::Zero(m_size);
    for (std::size_t k = 0; k < m_rows.size(); ++k) m_rows[k].scatter(forces[k], net);
    for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
      if (m_body_offset[bi] < 0) continue;
      ImplicitIntegrator& body = *m_bodies[bi].body;
      const Eigen::Index n = body.system_size();
      Eigen::VectorXd d = delta.segment(m_body_offset[bi], n);
      if (!body.has_pinned_nodes()) {
        // The solve's residual Σf − 𝒜δ, summed, is a force no contact exerted. A rigid
        // shift s changes 𝒜δ by m_scale M s and stores no strain: remove it with one.
        m_in = d;
        body.multiply_system(m_in, m_out);
        Vec3 unbalanced = Vec3::Zero();
        double mass = 0.0;
        for (Eigen::Index r = 0; r < n; r += 3) {
          unbalanced += net.segment<3>(m_body_offset[bi] + r) - m_out.segment<3>(r);
        }
        for (NodeIndex node = 0; node < body.node_count(); ++node) mass += body.node_masses()[node];
        const Vec3 shift = unbalanced / (body.system_mass_scale() * mass);
        for (Eigen::Index r = 0; r < n; r += 3) d.segment<3>(r) += shift;
      }
      body.correct_velocities(d, h);
    }
    for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
      if (m_projectile_offset[j] >= 0) {
        m_projectiles[j].velocity += net.segment<3>(m_projectile_offset[j]) / m_projectiles[j].mass;
      }
    }
  }

 private:
  /// out = op(in) on each body's block: the body's own system product or preconditioner.
  void for_each_body_block(const Eigen::VectorXd& in, Eigen::VectorXd& out,
                           void (ImplicitIntegrator::*op)(const Eigen::VectorXd&, Eigen::VectorXd&)) {
    for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
      if (m_body_offset[bi] < 0) continue;
      const Eigen::Index n = m_bodies[bi].body->system_size();
      m_in = in.segment(m_body_offset[bi], n);
      (m_bodies[bi].body->*op)(m_in, m_out);
      out.segment(m_body_offset[bi], n) = m_out;
    }
  }

  /// Adds a side's entries to the row; returns its lumped inverse mass along any direction.
  double add_side(const ContactSide& s, double sign, Row& row) const {
    if (s.kind == ContactSide::Kind::Projectile) {
      row.entries[row.count++] = {m_projectile_offset[s.owner], sign};
      return 1.0 / m_projectiles[s.owner].mass;
    }
    if (s.kind != ContactSide::Kind::Embedded || m_body_offset[s.owner] < 0) return 0.0;
    const ImplicitIntegrator& body = *m_bodies[s.owner].body;
    double inverse_mass = 0.0;
    for (int i = 0; i < 4; ++i) {
      const NodeIndex node = body.elasticity().tets()(i, s.tet);
      const Index r = body.system_row(node);
      if (r == kInvalidIndex || s.weight[i] == 0.0) continue;
      row.entries[row.count++] = {m_body_offset[s.owner] + static_cast<Eigen::Index>(r), sign * s.weight[i]};
      const double lumped = body.system_mass_scale() * body.node_masses()[node];
      const double diagonal = row.normal.dot(body.system_diagonal_block(node) * row.normal);
      inverse_mass += s.weight[i] * s.weight[i] / std::clamp(diagonal, lumped, kMaxStiffnessShare * lumped);
    }
    return inverse_mass;
  }

  [[nodiscard]] Vec3 velocity(const ContactSide& s) const {
    if (s.kind == ContactSide::Kind::Projectile) return m_projectiles[s.owner].velocity;
    if (s.kind != ContactSide::Kind::Embedded) return Vec3::Zero();
    const ImplicitIntegrator& body = *m_bodies[s.owner].body;
    Vec3 v = Vec3::Zero();
    for (int i = 0; i < 4; ++i) v += s.weight[i] * body.velocities().col(body.elasticity().tets()(i, s.tet));
    return v;
  }

  std::span<CollisionBody> m_bodies;
  std::span<Projectile> m_projectiles;
  std::vector<Eigen::Index> m_body_offset, m_projectile_offset;
  Eigen::Index m_size = 0;
  std::vector<Row> m_rows;
  std::vector<Index> m_contact_row;
  std::vector<Eigen::LDLT<Mat3>> m_projectile_block;
  Eigen::VectorXd m_in, m_out;  // scratch for the bodies' blocks
};

}  // namespace

ContactResponseReport respond_to_contacts(std::span<CollisionBody> bodies, std::span<Projectile> projectiles,
                                          std::span<ContactConstraint> contacts,
                                          const ContactResponseSettings& settings) {
  ContactResponseReport report;
  JointSystem system(bodies, projectiles, contacts);
  std::vector<Row>& rows = system.rows();
  if (rows.empty()) return report;
  // What each contact may still miss its target by when the iterations stop.
  std::vector<double> allowed(rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    allowed[k] = settings.relative_violation * std::max(std::abs(rows[k].required), settings.reference_speed);
  }
  const bool any_friction = std::any_of(rows.begin(), rows.end(), [](const Row& r) { return r.friction > 0.0; });

  Eigen::VectorXd delta = Eigen::VectorXd::Zero(system.size()), rhs(system.size());
  std::vector<Vec3> relative(rows.size());  // G δ per row
  std::vector<Vec3> forces(rows.size());    // what the last solve applied per row
  const auto measure = [&] {
    for (std::size_t k = 0; k < rows.size(); ++k) relative[k] = rows[k].apply(delta);
  };
  measure();
  const int max_outer = std::max(settings.iterations, any_friction ? 2 : 1);
  for (int outer = 0; outer < max_outer; ++outer) {
    // Active set and friction damping from the current estimate.
    rhs.setZero();
    for (std::size_t k = 0; k < rows.size(); ++k) {
      Row& row = rows[k];
      const double shortfall = row.required - row.normal.dot(relative[k]);
      row.active = row.lambda + row.kappa * shortfall > 0.0;
      row.eta = 0.0;
      if (row.friction > 0.0 && row.lambda > 0.0) {
        const Vec3 sliding = row.free_velocity + relative[k];
        const double tangential = (sliding - row.normal.dot(sliding) * row.normal).norm();
        row.eta = std::min(row.friction * row.lambda / std::max(tangential, kStickSpeed), kFrictionPenaltyRatio * row.kappa);
      }
      Vec3 f = -row.eta * (row.free_velocity - row.normal.dot(row.free_velocity) * row.normal);
      if (row.active) f += (row.lambda + row.kappa * row.required) * row.normal;
      row.scatter(f, rhs);
    }
    system.update_projectile_blocks();
    const ConjugateGradientResult cg = conjugate_gradient(
        [&](const Eigen::VectorXd& x, Eigen::VectorXd& y) { system.multiply(x, y); }, rhs, delta,
        [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { system.precondition(r, z); }, settings.tolerance,
        settings.max_cg_iterations);
    report.cg_iterations += cg.iterations;
    ++report.outer_iterations;
    measure();
    double violation = 0.0;
    bool unmet = false;
    for (std::size_t k = 0; k < rows.size(); ++k) {
      Row& row = rows[k];
      const double shortfall = row.required - row.normal.dot(relative[k]);
      // What this solve applied: 𝒜 δ = Σ forces (to its residual).
      forces[k] = row.force(relative[k], row.active ? row.lambda + row.kappa * shortfall : 0.0);
      const double lambda = std::max(0.0, row.lambda + row.kappa * shortfall);
      row.lambda = lambda;
      violation = std::max(violation, shortfall);
      unmet = unmet || shortfall > allowed[k];
    }
    report.largest_violation = violation;
    // Friction acts from the second iteration on (it needs the normal impulse), so with
    // friction one more solve.
    if (!unmet && (!any_friction || outer >= 1)) break;
  }

  system.apply(delta, forces, settings.dt);
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const Index r = system.row_of(k);
    contacts[k].impulse = r == kInvalidIndex ? 0.0 : rows[r].lambda;
  }
  return report;
}

}  // namespace fissure::sim
