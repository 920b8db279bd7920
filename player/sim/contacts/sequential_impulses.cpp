#include "player/sim/contacts/sequential_impulses.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "common/assert.h"

namespace fissure::sim::contact_detail {

namespace {

Mat3 cross_matrix(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

class SequentialImpulses {
 public:
  SequentialImpulses(JointSystem& system, const BlockJacobi& blocks, std::span<const RigidGroup> rigid)
      : m_system(system), m_rows(system.rows()), m_blocks(blocks), m_rigid(rigid) {
    place_rigid_groups();
    place_groups();
    m_contacts.resize(m_rows.size());
    std::size_t answers = 0;
    for (std::size_t k = 0; k < m_rows.size(); ++k) answers += find_groups(k, answers);
    m_answers.resize(answers);
    m_column_start.assign(static_cast<std::size_t>(m_local.size() / 3), kNoColumns);
    for (std::size_t k = 0; k < m_rows.size(); ++k) build_contact(k);
    // Warm start: the correction the rows' last impulses make.
    for (std::size_t k = 0; k < m_rows.size(); ++k) {
      m_contacts[k].impulse = Vec3(m_rows[k].lambda, 0.0, 0.0);
      move(m_contacts[k], m_contacts[k].impulse);
    }
  }

  /// One pass over the contacts in row order.
  void sweep() {
    for (std::size_t k = 0; k < m_rows.size(); ++k) solve_contact(k);
  }

  /// How far the contacts are from their targets now (solve_by_sequential_impulses).
  struct Violation {
    double largest = 0.0;
    bool short_of_target = false;  ///< a contact misses its target by more than its tolerance
    bool overshoots = false;       ///< a contact pushes while it separates faster than that
    bool unacceptable = false;     ///< a contact misses its target by more than it may at the cap
  };
  [[nodiscard]] Violation violation(std::span<const double> tolerance, std::span<const double> acceptable) const {
    Violation v;
    for (std::size_t k = 0; k < m_rows.size(); ++k) {
      const double shortfall = m_rows[k].required - relative_change(m_contacts[k])[0];
      v.largest = std::max(v.largest, shortfall);
      v.short_of_target = v.short_of_target || shortfall > tolerance[k];
      v.overshoots = v.overshoots || (m_contacts[k].impulse[0] > 0.0 && -shortfall > tolerance[k]);
      v.unacceptable = v.unacceptable || shortfall > acceptable[k];
    }
    return v;
  }

  /// The correction over the system's unknowns, the rows' forces, and each row's λ.
  void answer(SequentialImpulsesAnswer& out) {
    out.delta = Eigen::VectorXd::Zero(m_system.size());
    for (Index g = 0; g < static_cast<Index>(m_group_start.size()); ++g) {
      if (m_group_start[g] < 0) continue;
      const std::vector<Eigen::Index>& rows = m_blocks.group_rows(g);
      for (std::size_t i = 0; i < rows.size(); ++i) {
        out.delta.segment<3>(rows[i]) = m_local.segment<3>(m_group_start[g] + 3 * static_cast<Eigen::Index>(i));
      }
    }
    for (std::size_t r = 0; r < m_rigid.size(); ++r) {
      if (!m_rigid_touched[r]) continue;
      const RigidGroup& group = m_rigid[r];
      if (!group.small) ++out.rigid_groups_moved;
      for (std::size_t i = 0; i < group.rows.size(); ++i) {
        out.delta.segment<3>(group.rows[i]) = m_rigid_velocity[r] + m_rigid_spin[r].cross(group.arms[i]);
      }
    }
    out.forces.resize(m_rows.size());
    for (std::size_t k = 0; k < m_rows.size(); ++k) {
      out.forces[k] = m_contacts[k].frame * m_contacts[k].impulse;
      m_rows[k].lambda = m_contacts[k].impulse[0];
    }
  }

 private:
  /// One entry of a row: weight · δ at m_local's rows [local, local + 3).
  struct Reach {
    Eigen::Index local = 0;
    double weight = 0.0;
  };
  /// Group g's answer to the contact's unit impulses: 𝒜_g⁻¹ G_gᵀ F, rows × 3 at
  /// m_answers[answer] (column-major), for m_local's rows [first, first + rows).
  struct Response {
    Index group = kInvalidIndex;
    Eigen::Index first = 0, rows = 0;
    std::size_t answer = 0;
  };
  /// A side on a rigid group: it reads s V + Ω × a, with s = Σ wₑ, a = Σ wₑ rₑ.
  struct RigidSide {
    std::size_t group = 0;
    double weight = 0.0;
    Vec3 arm = Vec3::Zero();
  };
  struct Contact {
    std::array<Reach, 8> reach{};
    int count = 0;
    std::array<Response, 2> responses;  ///< a side is one fragment or projectile: two groups at most
    int response_count = 0;
    std::array<RigidSide, 2> rigid_sides;
    int rigid_count = 0;
    Mat3 frame, delassus;
    Eigen::Matrix2d tangent_inverse;  ///< the tangential corner of the Delassus block, inverted
    Vec3 free_velocity;  ///< in the frame
    Vec3 impulse;        ///< in the frame
  };

  /// Each rigid group's node by its first row; the groups start at rest.
  void place_rigid_groups() {
    m_rigid_node.assign(static_cast<std::size_t>(m_system.size() / 3), {kNotRigid, 0});
    for (std::size_t r = 0; r < m_rigid.size(); ++r) {
      for (std::size_t i = 0; i < m_rigid[r].rows.size(); ++i) m_rigid_node[m_rigid[r].rows[i] / 3] = {r, i};
    }
    m_rigid_velocity.assign(m_rigid.size(), Vec3::Zero());
    m_rigid_spin.assign(m_rigid.size(), Vec3::Zero());
    m_rigid_touched.assign(m_rigid.size(), false);
  }
  [[nodiscard]] bool is_rigid(Eigen::Index row) const { return m_rigid_node[row / 3].first != kNotRigid; }

  /// m_local holds δ on the groups the rows touch, each group's rows together.
  void place_groups() {
    m_group_start.assign(static_cast<std::size_t>(m_blocks.group_count()), -1);
    Eigen::Index size = 0;
    for (const Row& row : m_rows) {
      for (int e = 0; e < row.count; ++e) {
        if (is_rigid(row.entries[e].row)) continue;
        const Index g = m_blocks.group_of(row.entries[e].row);
        if (m_group_start[g] >= 0) continue;
        m_group_start[g] = size;
        size += 3 * static_cast<Eigen::Index>(m_blocks.group_rows(g).size());
      }
    }
    m_local = Eigen::VectorXd::Zero(size);
  }

  /// The contact's entries and groups; returns how many numbers its answers take, placed
  /// from m_answers[start].
  std::size_t find_groups(std::size_t k, std::size_t start) {
    const Row& row = m_rows[k];
    Contact& c = m_contacts[k];
    std::size_t size = 0;
    for (int e = 0; e < row.count; ++e) {
      if (is_rigid(row.entries[e].row)) {
        add_rigid_entry(c, row.entries[e]);
        continue;
      }
      const Index g = m_blocks.group_of(row.entries[e].row);
      c.reach[c.count++] = {m_group_start[g] + 3 * static_cast<Eigen::Index>(m_blocks.place_in_group(row.entries[e].row)),
                            row.entries[e].weight};
      if (c.response_count > 0 && c.responses[0].first == m_group_start[g]) continue;
      if (c.response_count > 1 && c.responses[1].first == m_group_start[g]) continue;
      const auto rows = 3 * static_cast<Eigen::Index>(m_blocks.group_rows(g).size());
      // Each side is one tet (or projectile) in one sealed block (JointSystem::sealed_groups).
      FISSURE_ASSERT(c.response_count + c.rigid_count < 2);
      c.responses[c.response_count++] = {g, m_group_start[g], rows, start + size};
      size += 3 * static_cast<std::size_t>(rows);
    }
    return size;
  }

  void add_rigid_entry(Contact& c, const Entry& entry) {
    const auto [group, node] = m_rigid_node[entry.row / 3];
    m_rigid_touched[group] = true;
    int side = 0;
    while (side < c.rigid_count && c.rigid_sides[side].group != group) ++side;
    if (side == c.rigid_count) {
      FISSURE_ASSERT(c.response_count + c.rigid_count < 2);
      c.rigid_sides[c.rigid_count++] = {group, 0.0, Vec3::Zero()};
    }
    c.rigid_sides[side].weight += entry.weight;
    c.rigid_sides[side].arm += entry.weight * m_rigid[group].arms[node];
  }

  /// 𝒜_g⁻¹ G_gᵀ F = Σ_e w_e (𝒜_g⁻¹'s three columns at node e) F per side, from the
  /// columns each node keeps (contacts next to each other share nodes), and
  /// D = Σ_sides (G_gᵀ F)ᵀ 𝒜_g⁻¹ G_gᵀ F.
  void build_contact(std::size_t k) {
    const Row& row = m_rows[k];
    Contact& c = m_contacts[k];
    c.frame = contact_frame(row.normal);
    c.free_velocity = c.frame.transpose() * row.free_velocity;
    c.delassus.setZero();
    for (int s = 0; s < c.response_count; ++s) {
      const Response& response = c.responses[s];
      auto answer = answer_of(response);
      answer.setZero();
      for (int e = 0; e < c.count; ++e) {
        const Eigen::Index local = c.reach[e].local - response.first;
        if (local < 0 || local >= response.rows) continue;
        answer.noalias() += (c.reach[e].weight * columns(response, local)).lazyProduct(c.frame);
      }
      for (int e = 0; e < c.count; ++e) {
        const Eigen::Index local = c.reach[e].local - response.first;
        if (local < 0 || local >= response.rows) continue;
        c.delassus.noalias() += c.reach[e].weight * c.frame.transpose() * answer.middleRows<3>(local);
      }
    }
    for (int s = 0; s < c.rigid_count; ++s) {
      const RigidSide& side = c.rigid_sides[s];
      const RigidGroup& group = m_rigid[side.group];
      const Mat3 arm = cross_matrix(side.arm);
      const Mat3 compliance =
          (side.weight * side.weight / group.mass) * Mat3::Identity() - arm * group.inverse_inertia * arm;
      c.delassus.noalias() += c.frame.transpose() * compliance * c.frame;
    }
    const Eigen::Matrix2d tangent = c.delassus.bottomRightCorner<2, 2>();
    c.tangent_inverse = tangent.determinant() > 0.0 ? Eigen::Matrix2d(tangent.inverse()) : Eigen::Matrix2d::Zero();
  }

  /// F_kᵀ G_k δ: what the correction so far adds to the contact's relative velocity.
  [[nodiscard]] Vec3 relative_change(const Contact& c) const {
    Vec3 g = Vec3::Zero();
    for (int e = 0; e < c.count; ++e) g += c.reach[e].weight * m_local.segment<3>(c.reach[e].local);
    for (int s = 0; s < c.rigid_count; ++s) {
      const RigidSide& side = c.rigid_sides[s];
      g += side.weight * m_rigid_velocity[side.group] + m_rigid_spin[side.group].cross(side.arm);
    }
    return c.frame.transpose() * g;
  }

  /// 𝒜_g⁻¹'s three columns for the node at rows [local, local + 3) of the group, made
  /// once per response.
  Eigen::Map<const Eigen::MatrixX3d> columns(const Response& r, Eigen::Index local) {
    std::size_t& start = m_column_start[static_cast<std::size_t>((r.first + local) / 3)];
    if (start == kNoColumns) {
      start = m_columns.size();
      m_columns.resize(start + 3 * static_cast<std::size_t>(r.rows));
      m_unit.setZero(r.rows, 3);
      m_unit.middleRows<3>(local).setIdentity();
      Eigen::Map<Eigen::MatrixX3d> out(m_columns.data() + start, r.rows, 3);
      m_blocks.solve_group(r.group, m_unit, out);
    }
    return {m_columns.data() + start, r.rows, 3};
  }

  [[nodiscard]] Eigen::Map<Eigen::MatrixX3d> answer_of(const Response& r) {
    return {m_answers.data() + r.answer, r.rows, 3};
  }

  /// δ += 𝒜⁻¹ G_kᵀ F_k change.
  void move(const Contact& c, const Vec3& change) {
    for (int s = 0; s < c.response_count; ++s) {
      const Response& r = c.responses[s];
      m_local.segment(r.first, r.rows).noalias() += answer_of(r).lazyProduct(change);
    }
    if (c.rigid_count == 0) return;
    const Vec3 impulse = c.frame * change;
    for (int s = 0; s < c.rigid_count; ++s) {
      const RigidSide& side = c.rigid_sides[s];
      const RigidGroup& group = m_rigid[side.group];
      m_rigid_velocity[side.group] += (side.weight / group.mass) * impulse;
      m_rigid_spin[side.group] += group.inverse_inertia * side.arm.cross(impulse);
    }
  }

  void solve_contact(std::size_t k) {
    Contact& c = m_contacts[k];
    if (!(c.delassus(0, 0) > 0.0)) return;
    Vec3 relative = relative_change(c);
    const Vec3 before = c.impulse;
    // The normal impulse that meets the target given the others', never pulling.
    c.impulse[0] = std::max(0.0, c.impulse[0] + (m_rows[k].required - relative[0]) / c.delassus(0, 0));
    relative += c.delassus.col(0) * (c.impulse[0] - before[0]);
    const double friction = m_rows[k].friction;
    if (friction > 0.0) {
      // The tangential impulse that stops the sliding, within the cone μ λ_n.
      const Eigen::Vector2d sliding = c.free_velocity.tail<2>() + relative.tail<2>();
      Eigen::Vector2d tangential = c.impulse.tail<2>() - c.tangent_inverse * sliding;
      const double cone = friction * c.impulse[0], size = tangential.norm();
      if (size > cone) tangential *= cone / size;
      c.impulse.tail<2>() = tangential;
    }
    move(c, c.impulse - before);
  }

  JointSystem& m_system;
  std::vector<Row>& m_rows;
  const BlockJacobi& m_blocks;
  std::span<const RigidGroup> m_rigid;
  static constexpr std::size_t kNotRigid = static_cast<std::size_t>(-1);
  std::vector<std::pair<std::size_t, std::size_t>> m_rigid_node;  ///< per node: its rigid group and place, or kNotRigid
  std::vector<Vec3> m_rigid_velocity, m_rigid_spin;                ///< per rigid group: V, Ω so far
  std::vector<bool> m_rigid_touched;
  std::vector<Eigen::Index> m_group_start;  ///< per group, its first row in m_local (−1: untouched)
  Eigen::VectorXd m_local;
  std::vector<Contact> m_contacts;
  std::vector<double> m_answers;        ///< every Response's answer
  static constexpr std::size_t kNoColumns = static_cast<std::size_t>(-1);
  std::vector<std::size_t> m_column_start;  ///< per node of m_local, its columns in m_columns
  std::vector<double> m_columns;
  Eigen::MatrixXd m_unit;                   ///< columns()' scratch
};

}  // namespace

SequentialImpulsesAnswer solve_by_sequential_impulses(JointSystem& system, std::span<const RigidGroup> rigid,
                                                      std::span<const double> tolerance,
                                                      std::span<const double> acceptable, int max_sweeps) {
  SequentialImpulsesAnswer out;
  SequentialImpulses solver(system, system.factor_base_blocks(), rigid);
  const bool any_friction =
      std::any_of(system.rows().begin(), system.rows().end(), [](const Row& r) { return r.friction > 0.0; });
  for (int sweep = 0; sweep < max_sweeps; ++sweep) {
    solver.sweep();
    ++out.sweeps;
    const auto violation = solver.violation(tolerance, acceptable);
    out.largest_violation = violation.largest;
    out.acceptable = !violation.unacceptable;
    // With friction one more sweep, as the augmented Lagrangian takes one more solve:
    // the first sweep's tangential impulses met normal impulses that were still moving.
    if (!violation.short_of_target && !violation.overshoots && (!any_friction || sweep >= 1)) {
      out.met = true;
      break;
    }
  }
  solver.answer(out);
  return out;
}

}  // namespace fissure::sim::contact_detail
