#include "player/sim/contacts/joint_system.h"

#include <algorithm>
#include <limits>

#include "player/sim/implicit_integrator.h"

namespace fissure::sim::contact_detail {

JointSystem::JointSystem(std::span<CollisionBody> bodies, std::span<Projectile> projectiles,
                         std::span<const ContactConstraint> contacts, const ContactSettings& settings)
    : m_bodies(bodies), m_projectiles(projectiles), m_contacts(contacts), m_settings(settings) {
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
    const bool a_moves = add_side(contacts[k].a, 1.0, row);
    const bool b_moves = add_side(contacts[k].b, -1.0, row);
    if (!a_moves && !b_moves) continue;  // nothing here can move
    row.free_velocity = velocity(contacts[k].a) - velocity(contacts[k].b);
    row.required = contacts[k].target - row.normal.dot(row.free_velocity);
    row.reach = contacts[k].reach;
    row.lambda = std::max(contacts[k].impulse, 0.0);
    m_contact_row[k] = static_cast<Index>(m_rows.size());
    m_rows.push_back(row);
  }
  build_blocks();
  build_node_entries();
}

bool JointSystem::use_sparse_blocks() {
  if (m_sparse_active || m_sparse_candidates.empty()) return false;
  m_sparse.set_groups(std::move(m_sparse_candidates), m_size);
  m_sparse_candidates.clear();
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    if (m_body_offset[bi] >= 0) add_fragment_systems(bi, m_sparse);
  }
  m_sparse.set_outer_rows(m_outer_rows);  // factored by the next update_blocks()
  m_body_needs_own.assign(m_bodies.size(), false);
  m_sparse_active = true;
  return true;
}

std::vector<bool> JointSystem::sealed_groups() const {
  const Index outside = m_blocks.group_count();  // a free node in no dense block
  std::vector<bool> sealed(static_cast<std::size_t>(outside), true);
  if (outside == 0) return sealed;  // no block to seal: skip the pass over every tet
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    if (m_body_offset[bi] < 0) continue;
    const ImplicitIntegrator& body = *m_bodies[bi].body;
    const Matrix4Xu& tets = body.elasticity().tets();
    for (Eigen::Index t = 0; t < tets.cols(); ++t) {
      std::array<Index, 4> group{};
      int free = 0;
      for (int c = 0; c < 4; ++c) {
        const Index r = body.system_row(tets(c, t));
        if (r == kInvalidIndex) continue;
        const Index g = m_blocks.group_of(m_body_offset[bi] + static_cast<Eigen::Index>(r));
        group[free++] = g == kInvalidIndex ? outside : g;
      }
      if (std::all_of(group.begin(), group.begin() + free, [&](Index g) { return g == group[0]; })) continue;
      for (int c = 0; c < free; ++c) {
        if (group[c] != outside) sealed[group[c]] = false;
      }
    }
  }
  return sealed;
}

const BlockJacobi& JointSystem::factor_base_blocks() {
  m_blocks.reset();
  m_blocks.factor();
  return m_blocks;
}

void JointSystem::multiply(const Eigen::VectorXd& x, Eigen::VectorXd& y) {
  multiply_mass(x, y);
  for_row_chunks(m_rows.size(), [&](std::size_t first, std::size_t last) {
    for (std::size_t k = first; k != last; ++k) {
      const Row& row = m_rows[k];
      const Vec3 g = row.apply(x);
      const double gn = row.normal.dot(g);
      Vec3 f = row.eta * (g - gn * row.normal);
      if (row.active) f += row.kappa * gn * row.normal;
      m_row_forces[k] = f;
    }
  });
  for_row_chunks(m_entry_nodes.size(), [&](std::size_t first, std::size_t last) {
    for (std::size_t n = first; n != last; ++n) {
      auto yn = y.segment<3>(m_entry_nodes[n]);
      for (std::size_t i = m_node_entry_start[n]; i < m_node_entry_start[n + 1]; ++i) {
        yn += m_node_entries[i].weight * m_row_forces[m_node_entries[i].row];
      }
    }
  });
}

void JointSystem::multiply_mass(const Eigen::VectorXd& x, Eigen::VectorXd& y) {
  y.resize(x.size());
  for_each_body_block(x, y, &ImplicitIntegrator::multiply_system);
  for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
    if (m_projectile_offset[j] >= 0) {
      y.segment<3>(m_projectile_offset[j]) = m_projectiles[j].mass * x.segment<3>(m_projectile_offset[j]);
    }
  }
}

void JointSystem::precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z) {
  z = Eigen::VectorXd::Zero(r.size());
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    if (m_body_offset[bi] < 0 || !m_body_needs_own[bi]) continue;
    const Eigen::Index offset = m_body_offset[bi], n = m_bodies[bi].body->system_size();
    m_in = r.segment(offset, n);
    for (Eigen::Index row = 0; row < n; row += 3) {
      if (m_blocks.covers(offset + row)) m_in.segment<3>(row).setZero();
    }
    m_bodies[bi].body->precondition_system(m_in, m_out);
    z.segment(offset, n) = m_out;
  }
  // What a left-out piece's block would give its zero residual (the body's own
  // preconditioner, factored before a split, may couple it to its old neighbours).
  for (const Eigen::Index row : m_left_out) z.segment<3>(row).setZero();
  m_blocks.solve(r, z);
  m_sparse.solve(r, z);
}

void JointSystem::update_blocks() {
  for_row_chunks(m_rows.size(), [&](std::size_t first, std::size_t last) {
    for (std::size_t k = first; k != last; ++k) {
      const Row& row = m_rows[k];
      const Mat3 nn = row.normal * row.normal.transpose();
      m_row_terms[k] = row.eta * (Mat3::Identity() - nn) + (row.active ? row.kappa : 0.0) * nn;
    }
  });
  m_blocks.set_outer_terms(m_row_terms);
  m_blocks.factor();
  if (m_sparse_active) m_sparse.set_outer_terms(m_row_terms, /*keep_large=*/true);
}

void JointSystem::apply(const Eigen::VectorXd& delta, const std::vector<Vec3>& forces, double h) {
  multiply_mass(delta, m_mass_delta);
  momentum_shifts(m_mass_delta, forces, m_shift);
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    if (m_body_offset[bi] < 0) continue;
    const Eigen::Index n = m_bodies[bi].body->system_size();
    const Eigen::VectorXd d = delta.segment(m_body_offset[bi], n) + m_shift.segment(m_body_offset[bi], n);
    m_bodies[bi].body->correct_velocities(d, h);
  }
  for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
    if (m_projectile_offset[j] >= 0) {
      m_projectiles[j].velocity += m_net.segment<3>(m_projectile_offset[j]) / m_projectiles[j].mass;
    }
  }
}

void JointSystem::apply_exact(const Eigen::VectorXd& delta, const std::vector<Vec3>& forces, double h) {
  m_net.setZero(m_size);
  for (std::size_t k = 0; k < m_rows.size(); ++k) m_rows[k].scatter(forces[k], m_net);
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    if (m_body_offset[bi] < 0) continue;
    m_bodies[bi].body->correct_velocities(delta.segment(m_body_offset[bi], m_bodies[bi].body->system_size()), h);
  }
  for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
    if (m_projectile_offset[j] >= 0) {
      m_projectiles[j].velocity += m_net.segment<3>(m_projectile_offset[j]) / m_projectiles[j].mass;
    }
  }
}

void JointSystem::momentum_shifts(const Eigen::VectorXd& mass_delta, const std::vector<Vec3>& forces, Eigen::VectorXd& shift) {
  m_net.setZero(m_size);
  for (std::size_t k = 0; k < m_rows.size(); ++k) m_rows[k].scatter(forces[k], m_net);
  shift.setZero(m_size);
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    if (m_body_offset[bi] < 0) continue;
    const Eigen::Index o = m_body_offset[bi], n = m_bodies[bi].body->system_size();
    balance_fragments(m_bodies[bi], m_net.segment(o, n), mass_delta.segment(o, n), shift.segment(o, n));
  }
  for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
    const Eigen::Index o = m_projectile_offset[j];
    if (o >= 0) shift.segment<3>(o) = (m_net.segment<3>(o) - mass_delta.segment<3>(o)) / m_projectiles[j].mass;
  }
}

Index JointSystem::map_node_fragments(const CollisionBody& b) {
  const Matrix4Xu& tets = b.body->elasticity().tets();
  m_node_fragment.assign(b.body->node_count(), 0);
  Index fragments = 1;
  if (b.tet_fragment == nullptr) return fragments;
  for (Eigen::Index t = 0; t < tets.cols(); ++t) {
    const Index f = (*b.tet_fragment)[t];
    for (int c = 0; c < 4; ++c) m_node_fragment[tets(c, t)] = f;
    fragments = std::max(fragments, f + 1);
  }
  return fragments;
}

void JointSystem::build_blocks() {
  std::vector<std::vector<Eigen::Index>> groups, sparse_groups;
  m_body_needs_own.assign(m_bodies.size(), false);
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    if (m_body_offset[bi] >= 0) add_fragment_groups(bi, groups, sparse_groups);
  }
  m_sparse_candidates = std::move(sparse_groups);
  m_sparse.set_groups({}, m_size);
  for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
    if (m_projectile_offset[j] >= 0) groups.push_back({m_projectile_offset[j]});
  }
  m_blocks.set_groups(std::move(groups), m_size);
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    if (m_body_offset[bi] >= 0) add_fragment_systems(bi, m_blocks);
  }
  for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
    const Eigen::Index r = m_projectile_offset[j];
    if (r >= 0) m_blocks.add(r, r, m_projectiles[j].mass * Mat3::Identity());
  }
  m_blocks.keep_as_base();
  m_outer_rows.resize(m_rows.size());
  for (std::size_t k = 0; k < m_rows.size(); ++k) {
    m_outer_rows[k].count = m_rows[k].count;
    for (int e = 0; e < m_rows[k].count; ++e) {
      m_outer_rows[k].rows[e] = m_rows[k].entries[e].row;
      m_outer_rows[k].weights[e] = m_rows[k].entries[e].weight;
    }
  }
  m_row_terms.resize(m_rows.size());
}

void JointSystem::build_node_entries() {
  std::vector<std::size_t> count(static_cast<std::size_t>(m_size / 3), 0);
  for (const Row& row : m_rows) {
    for (int e = 0; e < row.count; ++e) ++count[row.entries[e].row / 3];
  }
  std::vector<std::size_t> place(count.size(), 0);
  m_entry_nodes.clear();
  m_node_entry_start.assign(1, 0);
  for (std::size_t node = 0; node < count.size(); ++node) {
    if (count[node] == 0) continue;
    place[node] = m_node_entry_start.back();
    m_entry_nodes.push_back(3 * static_cast<Eigen::Index>(node));
    m_node_entry_start.push_back(m_node_entry_start.back() + count[node]);
  }
  m_node_entries.resize(m_node_entry_start.back());
  for (std::size_t k = 0; k < m_rows.size(); ++k) {
    for (int e = 0; e < m_rows[k].count; ++e) {
      const Entry& entry = m_rows[k].entries[e];
      m_node_entries[place[entry.row / 3]++] = {k, entry.weight};
    }
  }
  m_row_forces.resize(m_rows.size());
}

std::vector<bool> JointSystem::fragments_in_contact(std::size_t bi, Index fragments) const {
  const ImplicitIntegrator& body = *m_bodies[bi].body;
  const Eigen::Index offset = m_body_offset[bi], size = body.system_size();
  std::vector<Index> fragment_of(static_cast<std::size_t>(size / 3), kInvalidIndex);  // per free node
  for (NodeIndex node = 0; node < body.node_count(); ++node) {
    const Index r = body.system_row(node);
    if (r != kInvalidIndex) fragment_of[r / 3] = m_node_fragment[node];
  }
  std::vector<bool> touched(fragments, false);
  for (const Row& row : m_rows) {
    for (int e = 0; e < row.count; ++e) {
      const Eigen::Index local = row.entries[e].row - offset;
      if (local >= 0 && local < size) touched[fragment_of[local / 3]] = true;
    }
  }
  return touched;
}

void JointSystem::add_fragment_groups(std::size_t bi, std::vector<std::vector<Eigen::Index>>& groups,
                         std::vector<std::vector<Eigen::Index>>& sparse_groups) {
  const ImplicitIntegrator& body = *m_bodies[bi].body;
  const Index fragments = map_node_fragments(m_bodies[bi]);
  std::vector<Index> free_nodes(fragments, 0);
  for (NodeIndex node = 0; node < body.node_count(); ++node) {
    if (body.system_row(node) != kInvalidIndex) ++free_nodes[m_node_fragment[node]];
  }
  const std::vector<bool> in_contact = fragments_in_contact(bi, fragments);
  std::vector<Index> group(fragments, kInvalidIndex);
  for (NodeIndex node = 0; node < body.node_count(); ++node) {
    const Index r = body.system_row(node), f = m_node_fragment[node];
    if (r == kInvalidIndex) continue;
    const bool dense = free_nodes[f] <= m_settings.dense_fragment_nodes;
    if (!dense) {
      // The body's own preconditioner, until a response's solves show they need the
      // contacts on it (use_sparse_blocks).
      m_body_needs_own[bi] = true;
      if (!in_contact[f]) continue;
    } else if (!in_contact[f]) {
      // No block: its residual is zero and stays zero (no term couples it to another).
      // Shattered bodies are mostly such pieces, and each block costs an assembly and a
      // factorization per outer iteration.
      m_left_out.push_back(m_body_offset[bi] + static_cast<Eigen::Index>(r));
      continue;
    }
    auto& set = dense ? groups : sparse_groups;
    if (group[f] == kInvalidIndex) {
      group[f] = static_cast<Index>(set.size());
      set.emplace_back();
    }
    set[group[f]].push_back(m_body_offset[bi] + static_cast<Eigen::Index>(r));
  }
}

template <typename Blocks>
void JointSystem::add_fragment_systems(std::size_t bi, Blocks& blocks) {
  const ImplicitIntegrator& body = *m_bodies[bi].body;
  const Eigen::Index offset = m_body_offset[bi];
  const auto global_row = [&](NodeIndex node) -> Eigen::Index {
    const Index r = body.system_row(node);
    return r == kInvalidIndex ? -1 : offset + static_cast<Eigen::Index>(r);
  };
  for (NodeIndex node = 0; node < body.node_count(); ++node) {
    const Eigen::Index r = global_row(node);
    if (r >= 0 && blocks.covers(r)) {
      blocks.add(r, r, body.system_mass_scale() * body.node_masses()[node] * Mat3::Identity());
    }
  }
  const Matrix4Xu& tets = body.elasticity().tets();
  for (Eigen::Index t = 0; t < tets.cols(); ++t) {
    std::array<Eigen::Index, 4> rows{};
    bool covered = false;
    for (int c = 0; c < 4; ++c) {
      rows[c] = global_row(tets(c, t));
      covered = covered || (rows[c] >= 0 && blocks.covers(rows[c]));
    }
    if (!covered) continue;
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) {
        if (rows[i] >= 0 && rows[j] >= 0) {
          blocks.add(rows[i], rows[j], body.system_tet_block(static_cast<TetIndex>(t), i, j));
        }
      }
    }
  }
}

void JointSystem::balance_fragments(const CollisionBody& b, Eigen::Ref<const Eigen::VectorXd> net,
                       Eigen::Ref<const Eigen::VectorXd> mass_delta, Eigen::Ref<Eigen::VectorXd> shift) {
  ImplicitIntegrator& body = *b.body;
  const Index fragments = map_node_fragments(b);
  m_touched.assign(fragments, false);
  m_pinned.assign(fragments, false);
  for (NodeIndex node = 0; node < body.node_count(); ++node) {
    const Index f = m_node_fragment[node], r = body.system_row(node);
    if (r == kInvalidIndex) {
      m_pinned[f] = true;
    } else if (net.segment<3>(r).squaredNorm() > 0.0) {
      m_touched[f] = true;
    }
  }
  const auto shifted = [&](NodeIndex node) {
    const Index f = m_node_fragment[node];
    return body.system_row(node) != kInvalidIndex && m_touched[f] && !m_pinned[f];
  };
  Vec3 unbalanced = Vec3::Zero();
  double mass = 0.0;
  for (NodeIndex node = 0; node < body.node_count(); ++node) {
    if (!shifted(node)) continue;
    const Index r = body.system_row(node);
    unbalanced += net.segment<3>(r) - mass_delta.segment<3>(r);
    mass += body.node_masses()[node];
  }
  if (!(mass > 0.0)) return;
  const Vec3 rigid = unbalanced / (body.system_mass_scale() * mass);
  for (NodeIndex node = 0; node < body.node_count(); ++node) {
    if (shifted(node)) shift.segment<3>(body.system_row(node)) = rigid;
  }
}

void JointSystem::for_each_body_block(const Eigen::VectorXd& in, Eigen::VectorXd& out,
                         void (ImplicitIntegrator::*op)(const Eigen::VectorXd&, Eigen::VectorXd&)) {
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    if (m_body_offset[bi] < 0) continue;
    const Eigen::Index n = m_bodies[bi].body->system_size();
    m_in = in.segment(m_body_offset[bi], n);
    (m_bodies[bi].body->*op)(m_in, m_out);
    out.segment(m_body_offset[bi], n) = m_out;
  }
}

bool JointSystem::add_side(const ContactSide& s, double sign, Row& row) const {
  if (s.kind == ContactSide::Kind::Projectile) {
    row.entries[row.count++] = {m_projectile_offset[s.owner], sign};
    row.projectile = true;
    return m_projectiles[s.owner].mass < std::numeric_limits<double>::infinity();
  }
  if (s.kind != ContactSide::Kind::Embedded || m_body_offset[s.owner] < 0) return false;
  const ImplicitIntegrator& body = *m_bodies[s.owner].body;
  bool moves = false;
  for (int i = 0; i < 4; ++i) {
    const NodeIndex node = body.elasticity().tets()(i, s.tet);
    const Index r = body.system_row(node);
    if (r == kInvalidIndex || s.weight[i] == 0.0) continue;
    row.entries[row.count++] = {m_body_offset[s.owner] + static_cast<Eigen::Index>(r), sign * s.weight[i]};
    moves = true;
  }
  return moves;
}

double JointSystem::penalty_inverse_mass(const ContactSide& s, const Vec3& normal) const {
  if (s.kind == ContactSide::Kind::Projectile) return 1.0 / m_projectiles[s.owner].mass;
  if (s.kind != ContactSide::Kind::Embedded || m_body_offset[s.owner] < 0) return 0.0;
  const ImplicitIntegrator& body = *m_bodies[s.owner].body;
  double inverse_mass = 0.0;
  for (int i = 0; i < 4; ++i) {
    const NodeIndex node = body.elasticity().tets()(i, s.tet);
    if (body.system_row(node) == kInvalidIndex || s.weight[i] == 0.0) continue;
    const double lumped = body.system_mass_scale() * body.node_masses()[node];
    const double diagonal = normal.dot(body.system_diagonal_block(node) * normal);
    inverse_mass += s.weight[i] * s.weight[i] / std::clamp(diagonal, lumped, m_settings.max_stiffness_share * lumped);
  }
  return inverse_mass;
}

void JointSystem::set_penalties() {
  if (m_penalties_set) return;
  m_penalties_set = true;
  for (std::size_t k = 0; k < m_contacts.size(); ++k) {
    const Index r = m_contact_row[k];
    if (r == kInvalidIndex) continue;
    const double inverse_mass = penalty_inverse_mass(m_contacts[k].a, m_rows[r].normal) +
                                penalty_inverse_mass(m_contacts[k].b, m_rows[r].normal);
    m_rows[r].kappa = m_settings.penalty_ratio / inverse_mass;
  }
  m_blocks.set_outer_rows(m_outer_rows);
}

Vec3 JointSystem::velocity(const ContactSide& s) const {
  if (s.kind == ContactSide::Kind::Projectile) return m_projectiles[s.owner].velocity;
  if (s.kind != ContactSide::Kind::Embedded) return Vec3::Zero();
  const ImplicitIntegrator& body = *m_bodies[s.owner].body;
  Vec3 v = Vec3::Zero();
  for (int i = 0; i < 4; ++i) v += s.weight[i] * body.velocities().col(body.elasticity().tets()(i, s.tet));
  return v;
}

}  // namespace fissure::sim::contact_detail
