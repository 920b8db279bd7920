#include "player/sim/contacts/contact_response.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "player/sim/conjugate_gradient.h"
#include "player/sim/contacts/joint_system.h"
#include "player/sim/contacts/rigid_response.h"
#include "player/sim/contacts/sequential_impulses.h"
#include "player/sim/implicit_integrator.h"

namespace fissure::sim {

namespace {

using contact_detail::JointSystem;
using contact_detail::Row;
using contact_detail::tangential_part;

/// One outer iteration's problem, for fixed multipliers λ and friction damping η:
///   minimise φ(δ) = ½ δᵀ A_η δ − f_ηᵀ δ + Σ_k max(0, λ_k + κ_k s_k(δ))² / (2 κ_k),
/// with s_k(δ) = r_k − n_k · G_k δ the contact's shortfall, A_η = 𝒜 plus the friction
/// damping and f_η the damping's pull on the free sliding velocity. φ is convex and
/// piecewise quadratic; its pieces are the sets of active contacts (λ_k + κ_k s_k > 0).
/// Each outer iteration takes one Newton step on the current piece (one conjugate-
/// gradient solve) with an exact line search, so φ never increases. Taken whole, the
/// step cycled in a pile of fragments (issue 16): the solve with a contact active
/// overshot its target, the next left it inactive and missed the target by metres per
/// second, and every response ended on the missing half, so fragments sank with a
/// contact every step. Repeating the step until the piece holds before updating λ (the
/// exact inner minimum) bought little: on the bunny at toughness 0, 4 steps gave 2.1 mm
/// of sphere penetration at 344 ms of collisions per step, 1 step 3.4 mm at 280 ms.
class AugmentedLagrangian {
 public:
  AugmentedLagrangian(JointSystem& system, const ContactResponseSettings& settings)
      : m_system(system), m_rows(system.rows()), m_settings(settings),
        m_delta(Eigen::VectorXd::Zero(system.size())), m_relative(m_rows.size(), Vec3::Zero()),
        m_forces(m_rows.size(), Vec3::Zero()), m_step_relative(m_rows.size()),
        m_mass_delta(Eigen::VectorXd::Zero(system.size())),
        m_last_shortfall(m_rows.size(), std::numeric_limits<double>::infinity()), m_first_kappa(m_rows.size()) {
    for (std::size_t k = 0; k < m_rows.size(); ++k) m_first_kappa[k] = m_rows[k].kappa;
  }

  /// η_k = μ λ_k / |v_t| from the current estimate (lagged Coulomb friction), and the
  /// terms of φ that depend on it.
  void set_friction() {
    m_pull = Eigen::VectorXd::Zero(m_system.size());
    for (std::size_t k = 0; k < m_rows.size(); ++k) {
      Row& row = m_rows[k];
      row.eta = 0.0;
      if (row.friction > 0.0 && row.lambda > 0.0) {
        const double sliding = tangential_part(row, row.free_velocity + m_relative[k]).norm();
        row.eta = std::min(row.friction * row.lambda / std::max(sliding, m_settings.contacts.stick_speed),
                           m_settings.contacts.friction_penalty_ratio * row.kappa);
      }
      row.scatter(-row.eta * tangential_part(row, row.free_velocity), m_pull);
    }
  }

  /// The Newton step on the current piece, as far along as φ decreases; returns the
  /// conjugate-gradient iterations it took.
  int step() {
    for (std::size_t k = 0; k < m_rows.size(); ++k) m_rows[k].active = pushes(k);
    m_system.update_blocks();
    Eigen::VectorXd target = m_delta;
    const int iterations = solve_on_piece(target);
    const Eigen::VectorXd direction = target - m_delta;
    m_system.multiply_mass(direction, m_mass_direction);
    for (std::size_t k = 0; k < m_rows.size(); ++k) m_step_relative[k] = m_rows[k].apply(direction);
    const double t = step_length(direction);
    m_delta += t * direction;
    m_mass_delta += t * m_mass_direction;
    for (std::size_t k = 0; k < m_rows.size(); ++k) m_relative[k] += t * m_step_relative[k];
    return iterations;
  }

  /// λ_k ← max(0, λ_k + κ_k s_k). The forces kept for the momentum balance are what the
  /// step's piece exerts at δ (λ_k + κ_k s_k where active), for which 𝒜 δ = Σ forces up
  /// to the solve's residual when the step is taken whole. The updated λ_k instead,
  /// which the line-searched δ does not balance, made the rigid shift that evens out the
  /// balance (JointSystem::apply) add energy: ×2.24 in the stability grid's soft, nearly
  /// incompressible case at dt = 0.1. Returns the largest shortfall, and whether any
  /// contact misses what it is allowed, both of the velocities apply() will leave.
  std::pair<double, bool> update_multipliers(std::span<const double> allowed) {
    for (std::size_t k = 0; k < m_rows.size(); ++k) {
      Row& row = m_rows[k];
      const double shortfall = this->shortfall(k);
      m_forces[k] = row.force(m_relative[k], row.active ? row.lambda + row.kappa * shortfall : 0.0);
      row.lambda = std::max(0.0, row.lambda + row.kappa * shortfall);
    }
    // The shift that balances momentum is part of the answer, so the targets are judged
    // with it (stationarity, the KKT condition the shortfalls alone do not check). Judged
    // on δ alone, a line search that stopped short (t = 0.46, four contacts just turned
    // off) left 𝒜δ pushing a heavy bar up 253 m/s more than its contacts did; the shift
    // took that back after the iterations had stopped, and the bar sank 12.7 m into the
    // ground in one substep (issue 16).
    m_system.momentum_shifts(m_mass_delta, m_forces, m_shift);
    double violation = 0.0;
    bool unmet = false;
    for (std::size_t k = 0; k < m_rows.size(); ++k) {
      const double shortfall = this->shortfall(k) - m_rows[k].normal.dot(m_rows[k].apply(m_shift));
      violation = std::max(violation, shortfall);
      // Both halves of complementarity: a contact must not fall short of its target,
      // nor push while it already separates faster than asked (that push is work done
      // on the bodies, energy no contact may add).
      const bool overshoots = m_rows[k].lambda > 0.0 && -shortfall > allowed[k];
      unmet = unmet || shortfall > allowed[k] || overshoots;
      if (shortfall > allowed[k]) stiffen_if_stalled(k, shortfall);
      m_last_shortfall[k] = shortfall;
    }
    return {violation, unmet};
  }

  [[nodiscard]] const Eigen::VectorXd& delta() const { return m_delta; }
  [[nodiscard]] const std::vector<Vec3>& forces() const { return m_forces; }

 private:
  /// κ_k grows where contact k pushed and still falls short by more than
  /// ContactSettings::stalled_shortfall_share of its last shortfall, or falls short
  /// where the last outer iteration met or overshot its target (it swings).
  void stiffen_if_stalled(std::size_t k, double shortfall) {
    const ContactSettings& settings = m_settings.contacts;
    Row& row = m_rows[k];
    if (!row.active || row.projectile || shortfall <= settings.stalled_shortfall_share * m_last_shortfall[k]) return;
    row.kappa = std::min(settings.stalled_penalty_growth * row.kappa, settings.max_penalty_growth * m_first_kappa[k]);
  }

  [[nodiscard]] double shortfall(std::size_t k) const {
    return m_rows[k].required - m_rows[k].normal.dot(m_relative[k]);
  }
  [[nodiscard]] bool pushes(std::size_t k) const { return m_rows[k].lambda + m_rows[k].kappa * shortfall(k) > 0.0; }

  /// The minimiser of φ on the current piece, from the guess in x (warm start).
  int solve_on_piece(Eigen::VectorXd& x) {
    Eigen::VectorXd rhs = m_pull;
    for (const Row& row : m_rows) {
      if (row.active) row.scatter((row.lambda + row.kappa * row.required) * row.normal, rhs);
    }
    return conjugate_gradient([&](const Eigen::VectorXd& in, Eigen::VectorXd& out) { m_system.multiply(in, out); },
                              rhs, x,
                              [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { m_system.precondition(r, z); },
                              m_settings.contacts.tolerance, m_settings.contacts.max_cg_iterations,
                              m_settings.contacts.inner_reduction)
        .iterations;
  }

  /// The t ≥ 0 that minimises φ(δ + t d): the root of φ' along d, which is increasing
  /// and piecewise linear (a contact's term bends where it turns on or off). 𝒜 δ is
  /// kept from step to step, so this costs one product with 𝒜, for 𝒜 d, and a pass over
  /// the rows per trial t. Newton's method, kept inside a bracket of the root (bisection
  /// where it would leave it): on a linear piece it lands on the root in one step, so it
  /// takes a few passes where plain bisection took 40.
  double step_length(const Eigen::VectorXd& direction) {
    double curvature = direction.dot(m_mass_direction);
    double slope_at_start = direction.dot(m_mass_delta - m_pull);
    for (std::size_t k = 0; k < m_rows.size(); ++k) {
      const Row& row = m_rows[k];
      const Vec3 sliding_change = tangential_part(row, m_step_relative[k]);
      curvature += row.eta * sliding_change.squaredNorm();
      slope_at_start += row.eta * sliding_change.dot(m_relative[k]);
    }
    // φ'(t) and φ''(t) (the slope of the piece t is on).
    const auto slope = [&](double t) {
      double s = slope_at_start + t * curvature, bend = curvature;
      for (std::size_t k = 0; k < m_rows.size(); ++k) {
        const Row& row = m_rows[k];
        const double along = row.normal.dot(m_step_relative[k]);
        const double push = row.lambda + row.kappa * (shortfall(k) - t * along);
        if (push > 0.0) {
          s -= push * along;
          bend += row.kappa * along * along;
        }
      }
      return std::pair{s, bend};
    };
    const double start = slope(0.0).first;
    if (!(start < 0.0)) return 0.0;  // the inexact solve gave no descent
    constexpr double kLongest = 64.0;
    constexpr double kRelativeWidth = 1e-12;  // about the 40 bisections of [0, 1] this replaced
    constexpr int kMostTrials = 100;
    double below = 0.0, above = kLongest, t = 1.0;
    for (int trial = 0; trial < kMostTrials; ++trial) {
      const auto [s, bend] = slope(t);
      if (s == 0.0) return t;
      (s < 0.0 ? below : above) = t;
      if (above - below <= kRelativeWidth * above) break;
      const double newton = t - s / bend;
      if (std::abs(newton - t) <= kRelativeWidth * t) return newton;  // on the root's piece
      t = newton > below && newton < above ? newton : 0.5 * (below + above);
    }
    return 0.5 * (below + above);
  }

  JointSystem& m_system;
  std::vector<Row>& m_rows;
  const ContactResponseSettings& m_settings;
  Eigen::VectorXd m_delta;
  std::vector<Vec3> m_relative;  ///< G δ per row
  std::vector<Vec3> m_forces;    ///< each row's force for the last multipliers
  std::vector<Vec3> m_step_relative;  ///< G d per row, for the step's direction d
  Eigen::VectorXd m_pull;        ///< f_η
  Eigen::VectorXd m_mass_delta, m_mass_direction;  ///< 𝒜 δ, 𝒜 d
  Eigen::VectorXd m_shift;       ///< what apply() will add to δ (JointSystem::momentum_shifts)
  std::vector<double> m_last_shortfall;  ///< per row, after the last outer iteration
  std::vector<double> m_first_kappa;     ///< per row, as JointSystem::set_penalties left it
};

/// Each contact's normal impulse, the next step's warm start.
void write_impulses(const JointSystem& system, std::span<ContactConstraint> contacts) {
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const Index r = system.row_of(k);
    contacts[k].impulse = r == kInvalidIndex ? 0.0 : system.rows()[r].lambda;
  }
}

/// What each contact may still miss its target by when the iterations stop.
std::vector<double> allowed_misses(const std::vector<Row>& rows, const ContactResponseSettings& settings) {
  std::vector<double> allowed(rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    allowed[k] = settings.contacts.allowed_miss(rows[k].required, rows[k].reach, settings.dt, settings.reference_speed);
  }
  return allowed;
}

/// The augmented Lagrangian's answer, applied.
void answer_by_lagrangian(JointSystem& system, const ContactResponseSettings& settings, ContactResponseReport& report) {
  std::vector<Row>& rows = system.rows();
  const std::vector<double> allowed = allowed_misses(rows, settings);
  const bool any_friction = std::any_of(rows.begin(), rows.end(), [](const Row& r) { return r.friction > 0.0; });
  system.set_penalties();
  AugmentedLagrangian solver(system, settings);
  const int max_outer = std::max(settings.contacts.iterations, any_friction ? 2 : 1);
  if (settings.sparse_blocks_from_start) system.use_sparse_blocks();
  double last_violation = 0.0;
  for (int outer = 0; outer < max_outer; ++outer) {
    solver.set_friction();
    const int iterations = solver.step();
    report.cg_iterations += iterations;
    if (iterations > settings.contacts.sparse_blocks_after) {
      report.ran_long = true;
      system.use_sparse_blocks();
    }
    ++report.outer_iterations;
    const auto [violation, unmet] = solver.update_multipliers(allowed);
    last_violation = violation;
    // Friction acts from the second iteration on (it needs the normal impulse), so with
    // friction one more solve.
    if (!unmet && (!any_friction || outer >= 1)) break;
  }
  report.largest_violation = std::max(report.largest_violation, last_violation);
  system.apply(solver.delta(), solver.forces(), settings.dt);
}

/// The sequential impulses' answer, applied if it is kept (needs every row to read only
/// sealed dense blocks: debris_contacts); otherwise the augmented Lagrangian's.
///
/// The sweeps stop on the augmented Lagrangian's rule, each contact's tolerance never
/// more than a share of its reach per step: they stop exactly at their tolerance, where
/// the augmented Lagrangian's Newton steps land well inside it (at dt = 0.1 s, where a
/// step of gravity is 1,000 m/s, a tolerance of a whole reach per step let a tumbling
/// bar sink 0.18 m). At the cap, the answer is kept if no contact falls short by more
/// than that share of its reach (it sinks at most that much in the step, and the
/// push-out of the next steps takes it back).
///
/// Resting large fragments take part as rigid groups (rigid_response.h); if the answer is
/// not kept, the augmented Lagrangian answers them deformably with the rest.
void answer_debris(JointSystem& system, std::span<const contact_detail::RigidGroup> rigid,
                   const ContactResponseSettings& settings, ContactResponseReport& report) {
  std::vector<Row>& rows = system.rows();
  const std::vector<double> allowed = allowed_misses(rows, settings);
  std::vector<double> tolerance(allowed), acceptable(allowed);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    acceptable[k] = settings.contacts.acceptable_sweep_miss(allowed[k], rows[k].reach, settings.dt);
    tolerance[k] = std::min(allowed[k], acceptable[k]);
  }
  std::vector<double> last_steps(rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) last_steps[k] = rows[k].lambda;
  const contact_detail::SequentialImpulsesAnswer answer =
      contact_detail::solve_by_sequential_impulses(system, rigid, tolerance, acceptable,
                                                   settings.contacts.sequential_impulse_sweeps);
  report.sweeps += answer.sweeps;
  report.swept_to_cap = report.swept_to_cap || !answer.met;
  if (answer.acceptable) {
    report.rigid_answers += answer.rigid_groups_moved;
    report.largest_violation = std::max(report.largest_violation, answer.largest_violation);
    system.apply_exact(answer.delta, answer.forces, settings.dt);
    return;
  }
  // The augmented Lagrangian starts from the last step's impulses, not the sweeps':
  // from those, its Newton steps left a tumbling bar at dt = 0.1 s 0.18 m deep (0.03 m
  // from the last step's).
  for (std::size_t k = 0; k < rows.size(); ++k) rows[k].lambda = last_steps[k];
  answer_by_lagrangian(system, settings, report);
}

/// Whether any row reads a dense block: if none (an intact body on the ground), there
/// is no debris to find, and no pass over the bodies' tets to find it.
bool touches_dense_blocks(const JointSystem& system) {
  return std::any_of(system.rows().begin(), system.rows().end(), [&](const Row& row) {
    return std::any_of(row.entries.begin(), row.entries.begin() + row.count,
                       [&](const contact_detail::Entry& e) { return system.blocks().covers(e.row); });
  });
}

/// Union–find over the units a contact row can touch.
class Islands {
 public:
  explicit Islands(std::size_t units) : m_parent(units) { std::iota(m_parent.begin(), m_parent.end(), Index{0}); }
  Index root(Index u) {
    while (m_parent[u] != u) u = m_parent[u] = m_parent[m_parent[u]];
    return u;
  }
  void join(Index u, Index v) { m_parent[root(u)] = root(v); }
  [[nodiscard]] std::size_t size() const { return m_parent.size(); }

 private:
  std::vector<Index> m_parent;
};

/// Each entry's unit: its dense block if sealed, its rigid group, or else the one large piece.
class RowUnits {
 public:
  RowUnits(const JointSystem& system, std::span<const contact_detail::RigidGroup> rigid)
      : m_blocks(system.blocks()), m_sealed(system.sealed_groups()), m_large(m_blocks.group_count()),
        m_rigid_unit(static_cast<std::size_t>(system.size() / 3), kInvalidIndex) {
    for (std::size_t r = 0; r < rigid.size(); ++r) {
      for (const Eigen::Index row : rigid[r].rows) m_rigid_unit[row / 3] = rigid_unit(r);
    }
  }
  /// Units: the dense blocks, then the one large piece, then the rigid groups.
  [[nodiscard]] std::size_t count(std::size_t rigid_groups) const {
    return static_cast<std::size_t>(m_large) + 1 + rigid_groups;
  }
  [[nodiscard]] Index large() const { return m_large; }
  [[nodiscard]] Index rigid_unit(std::size_t r) const { return m_large + 1 + static_cast<Index>(r); }
  [[nodiscard]] Index of(const contact_detail::Entry& e) const {
    if (m_rigid_unit[e.row / 3] != kInvalidIndex) return m_rigid_unit[e.row / 3];
    const Index g = m_blocks.group_of(e.row);
    return g == kInvalidIndex || !m_sealed[g] ? m_large : g;
  }
  /// A row's entries all lie in one island once the rows are joined: its first one's.
  [[nodiscard]] Index of(const Row& row) const { return of(row.entries[0]); }

 private:
  const BlockJacobi& m_blocks;
  std::vector<bool> m_sealed;
  Index m_large;
  std::vector<Index> m_rigid_unit;  ///< per node of the system: its rigid group's unit, or invalid
};

/// Joins to the large piece each island that holds a resting fragment and a hit: a
/// projectile's contact, or one asking more than rigid_asked_speed. A ball on a pebble
/// that lies on a resting piece reaches the piece through the pebble in the same answer,
/// and must find it deformable, free to break.
void join_hit_rigid_islands(const JointSystem& system, std::span<const ContactConstraint> contacts,
                            std::span<const contact_detail::RigidGroup> rigid, const RowUnits& units,
                            const ContactResponseSettings& settings, Islands& islands) {
  const double asked = settings.contacts.rigid_asked_speed(settings.reference_speed);
  std::vector<bool> hit(islands.size(), false), holds_rigid(islands.size(), false);
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const Index r = system.row_of(k);
    if (r == kInvalidIndex) continue;
    const bool projectile = contacts[k].a.kind == ContactSide::Kind::Projectile ||
                            contacts[k].b.kind == ContactSide::Kind::Projectile;
    if (projectile || std::abs(system.rows()[r].required) > asked) hit[islands.root(units.of(system.rows()[r]))] = true;
  }
  // A small fragment is rigid whatever hits it; only a resting large one must break.
  for (std::size_t r = 0; r < rigid.size(); ++r) {
    if (!rigid[r].small) holds_rigid[islands.root(units.rigid_unit(r))] = true;
  }
  for (Index u = 0; u < static_cast<Index>(islands.size()); ++u) {
    if (islands.root(u) == u && hit[u] && holds_rigid[u]) islands.join(u, units.large());
  }
}

/// Per contact: whether its island (the contacts joined through the small fragments,
/// resting large fragments and projectiles they touch) reads only sealed dense blocks
/// (JointSystem::sealed_groups) and rigid groups, so the sequential impulses can answer
/// it. The other large fragments (and any block a tet joins to another) all count as one
/// piece: every contact that touches one goes to the augmented Lagrangian, with
/// everything joined to it; so does an island with a resting fragment and a hit
/// (join_hit_rigid_islands).
std::vector<bool> debris_contacts(const JointSystem& system, std::span<const contact_detail::RigidGroup> rigid,
                                  std::span<const ContactConstraint> contacts, const ContactResponseSettings& settings) {
  const RowUnits units(system, rigid);
  Islands islands(units.count(rigid.size()));
  for (const Row& row : system.rows()) {
    for (int e = 1; e < row.count; ++e) islands.join(units.of(row.entries[e]), units.of(row.entries[0]));
  }
  if (!rigid.empty()) join_hit_rigid_islands(system, contacts, rigid, units, settings, islands);
  std::vector<bool> debris(contacts.size(), false);
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const Index r = system.row_of(k);
    if (r != kInvalidIndex) debris[k] = islands.root(units.of(system.rows()[r])) != islands.root(units.large());
  }
  return debris;
}

/// The response: the debris' islands (small fragments, resting large fragments as rigid
/// bodies, projectiles) by sequential impulses, the rest by the augmented Lagrangian.
void respond(std::span<CollisionBody> bodies, std::span<Projectile> projectiles,
             std::span<ContactConstraint> contacts, std::span<const contact_detail::RestingFragment> resting,
             const ContactResponseSettings& settings, ContactResponseReport& report) {
  JointSystem system(bodies, projectiles, contacts, settings.contacts);
  if (system.rows().empty()) return;
  if (settings.contacts.sequential_impulse_sweeps <= 0 || (resting.empty() && !touches_dense_blocks(system))) {
    answer_by_lagrangian(system, settings, report);
    write_impulses(system, contacts);
    return;
  }
  // A contact without a row (nothing it touches can move) counts as neither.
  const std::vector<contact_detail::RigidGroup> rigid = contact_detail::rigid_groups(bodies, resting, system);
  const std::vector<bool> debris = debris_contacts(system, rigid, contacts, settings);
  const auto debris_count = static_cast<std::size_t>(std::count(debris.begin(), debris.end(), true));
  if (debris_count == system.rows().size() || debris_count == 0) {
    if (debris_count == 0) {
      answer_by_lagrangian(system, settings, report);
    } else {
      answer_debris(system, rigid, settings, report);
    }
    write_impulses(system, contacts);
    return;
  }
  // Two problems on disjoint unknowns: the debris' islands, and the rest. Both systems
  // read the velocities before either answer moves them.
  std::vector<ContactConstraint> debris_part, rest_part;
  for (std::size_t k = 0; k < contacts.size(); ++k) (debris[k] ? debris_part : rest_part).push_back(contacts[k]);
  JointSystem debris_system(bodies, projectiles, debris_part, settings.contacts),
      rest_system(bodies, projectiles, rest_part, settings.contacts);
  answer_debris(debris_system, contact_detail::rigid_groups(bodies, resting, debris_system), settings, report);
  answer_by_lagrangian(rest_system, settings, report);
  write_impulses(debris_system, debris_part);
  write_impulses(rest_system, rest_part);
  std::size_t next_debris = 0, next_rest = 0;
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    contacts[k].impulse = debris[k] ? debris_part[next_debris++].impulse : rest_part[next_rest++].impulse;
  }
}

}  // namespace

ContactResponseReport respond_to_contacts(std::span<CollisionBody> bodies, std::span<Projectile> projectiles,
                                          std::span<ContactConstraint> contacts,
                                          const ContactResponseSettings& settings) {
  ContactResponseReport report;
  const std::vector<contact_detail::RestingFragment> resting =
      contact_detail::resting_fragments(bodies, contacts, settings.contacts, settings.reference_speed);
  respond(bodies, projectiles, contacts, resting, settings, report);
  return report;
}

}  // namespace fissure::sim
