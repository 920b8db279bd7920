#include "player/sim/contact_response.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "player/sim/block_jacobi.h"
#include "player/sim/conjugate_gradient.h"
#include "player/sim/sparse_blocks.h"

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

/// A fragment with at most this many free nodes gets a dense block of the response's
/// operator, its contacts' terms included, as its preconditioner (BlockJacobi); larger
/// ones keep their body's own. A 64-node block is 192×192, about 2.4 Mflop to factor
/// once per outer iteration. At 32, the bunny at toughness 0 kept one fragment of 34–52
/// nodes above it for most of the run, and with it the whole body's own preconditioner:
/// the response took 3× the CG iterations of a run where no fragment was above it.
constexpr Index kDenseFragmentNodes = 64;

/// Contact rows (or nodes) per parallel task: each is a few dozen flops.
constexpr std::size_t kRowsPerTask = 512;

/// f(first, last) over [0, count) in parallel chunks of at least kRowsPerTask; in this
/// thread when that is one chunk (a scene with a few dozen contacts pays no task
/// scheduling per product).
template <typename F>
void for_row_chunks(std::size_t count, const F& f) {
  if (count <= kRowsPerTask) {
    f(std::size_t{0}, count);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, kRowsPerTask),
                    [&](const tbb::blocked_range<std::size_t>& range) { f(range.begin(), range.end()); });
}

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
  double reach = 0;    ///< ContactConstraint::reach [m]
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

/// v minus its part along the row's normal.
Vec3 tangential_part(const Row& row, const Vec3& v) { return v - row.normal.dot(v) * row.normal; }

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
      row.reach = contacts[k].reach;
      row.lambda = std::max(contacts[k].impulse, 0.0);
      m_contact_row[k] = static_cast<Index>(m_rows.size());
      m_rows.push_back(row);
    }
    build_blocks();
    build_node_entries();
  }

  [[nodiscard]] Eigen::Index size() const { return m_size; }

  /// From now on, each large fragment a contact touches is preconditioned by its own
  /// sparse block, its contacts' terms included, in place of its body's own
  /// preconditioner; false if there is none. Made on demand: a block costs a sparse
  /// factorization per outer iteration, which pays only where the solves without it are
  /// long (a large fragment in a pile of small ones). Once they are used, no body's own
  /// preconditioner is: it would solve over the whole body, every fragment of it, for
  /// each conjugate-gradient iteration, to serve the large fragments that touch only
  /// obstacles. A fragment no contact touches is left out: its residual is zero and
  /// stays zero, since no term couples it to another.
  bool use_sparse_blocks() {
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
  std::vector<Row>& rows() { return m_rows; }
  [[nodiscard]] Index row_of(std::size_t contact) const { return m_contact_row[contact]; }

  /// y = (𝒜 + Σ_active κ n nᵀ ⊗ G + Σ η Gᵀ T G) x. Each row's force in parallel, then
  /// each node's share of them in row order: the sums a serial pass over the rows makes,
  /// whatever the thread count.
  void multiply(const Eigen::VectorXd& x, Eigen::VectorXd& y) {
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

  /// y = 𝒜 x: the bodies' systems and the projectiles' masses, without the contacts.
  void multiply_mass(const Eigen::VectorXd& x, Eigen::VectorXd& y) {
    y.resize(x.size());
    for_each_body_block(x, y, &ImplicitIntegrator::multiply_system);
    for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
      if (m_projectile_offset[j] >= 0) {
        y.segment<3>(m_projectile_offset[j]) = m_projectiles[j].mass * x.segment<3>(m_projectile_offset[j]);
      }
    }
  }

  /// The dense blocks (small fragments, projectiles) exactly, contacts included, and the
  /// sparse ones once made; the bodies' own preconditioners on the rest until then (a
  /// body needs its own only while no sparse block is made: use_sparse_blocks()). The
  /// own one sees no row of a dense block (those are zeroed on the way in), so together
  /// they stay symmetric.
  void precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z) {
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
    m_blocks.solve(r, z);
    m_sparse.solve(r, z);
  }

  /// The blocks of the current operator: the base (system and masses) plus each row's
  /// terms between entries in one block. A large sparse block keeps the factor of the
  /// first outer iteration that made it (SparseBlocks::kKeptFactorNodes): the contacts
  /// turned on or off and the friction since then make it stale, which costs CG
  /// iterations, fewer than its factorizations did.
  void update_blocks() {
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

  /// Applies the correction: bodies move by it (the fragments it touched rigidly
  /// shifted so that together they gain exactly the impulses they received),
  /// projectiles take exactly their impulses.
  void apply(const Eigen::VectorXd& delta, const std::vector<Vec3>& forces, double h) {
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

  /// What apply() adds to a correction δ whose 𝒜δ is `mass_delta`, for the contact
  /// forces `forces`: on each body, the rigid shift of balance_fragments on the nodes it
  /// moves; on each projectile, the velocity that makes it gain exactly its own impulses
  /// (apply() gives a projectile Σf / m and ignores its δ). Also leaves Σf in m_net.
  void momentum_shifts(const Eigen::VectorXd& mass_delta, const std::vector<Vec3>& forces, Eigen::VectorXd& shift) {
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

 private:
  /// m_node_fragment = each node's fragment (after a split a node is in one); returns
  /// the number of fragments.
  Index map_node_fragments(const CollisionBody& b) {
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

  /// One dense block per fragment with at most kDenseFragmentNodes free nodes (a whole
  /// small body counts as one fragment) and per projectile; their base values: the
  /// mass terms and the fragment's tets' system blocks.
  void build_blocks() {
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
    m_blocks.set_outer_rows(m_outer_rows);
    m_row_terms.resize(m_rows.size());
  }

  /// The nodes the rows touch, and each one's entries in the rows in row order
  /// (multiply()'s second pass).
  void build_node_entries() {
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

  /// Per fragment of body bi (m_node_fragment): whether a contact row has an entry on it.
  std::vector<bool> fragments_in_contact(std::size_t bi, Index fragments) const {
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

  /// Body bi's small fragments as groups of their free nodes' rows, in node order.
  void add_fragment_groups(std::size_t bi, std::vector<std::vector<Eigen::Index>>& groups,
                           std::vector<std::vector<Eigen::Index>>& sparse_groups) {
    const ImplicitIntegrator& body = *m_bodies[bi].body;
    const Index fragments = map_node_fragments(m_bodies[bi]);
    std::vector<Index> free_nodes(fragments, 0);
    for (NodeIndex node = 0; node < body.node_count(); ++node) {
      if (body.system_row(node) != kInvalidIndex) ++free_nodes[m_node_fragment[node]];
    }
    const bool any_large =
        std::any_of(free_nodes.begin(), free_nodes.end(), [](Index n) { return n > kDenseFragmentNodes; });
    const std::vector<bool> in_contact = any_large ? fragments_in_contact(bi, fragments) : std::vector<bool>();
    std::vector<Index> group(fragments, kInvalidIndex);
    for (NodeIndex node = 0; node < body.node_count(); ++node) {
      const Index r = body.system_row(node), f = m_node_fragment[node];
      if (r == kInvalidIndex) continue;
      const bool dense = free_nodes[f] <= kDenseFragmentNodes;
      if (!dense) {
        // The body's own preconditioner, until a response's solves show they need the
        // contacts on it (use_sparse_blocks).
        m_body_needs_own[bi] = true;
        if (!in_contact[f]) continue;
      }
      auto& set = dense ? groups : sparse_groups;
      if (group[f] == kInvalidIndex) {
        group[f] = static_cast<Index>(set.size());
        set.emplace_back();
      }
      set[group[f]].push_back(m_body_offset[bi] + static_cast<Eigen::Index>(r));
    }
  }

  /// Body bi's system A on `blocks` (dense or sparse): each covered node's mass term,
  /// and each covered tet's blocks between its free corners.
  template <typename Blocks>
  void add_fragment_systems(std::size_t bi, Blocks& blocks) {
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

  /// The solve's residual Σf − 𝒜δ, summed, is a force no contact exerted. A rigid
  /// shift s changes 𝒜δ by m_scale M s (the stiffness does not see it) and stores no
  /// strain: remove it with one, shared by the fragments the contacts touched and free
  /// of pins (pins take their own). Shared by the whole body, a piece with no contact
  /// took a share of the others' imbalance (ContactResponse tests). Per fragment, each
  /// piece would gain exactly its own impulses, but one-tet pieces took their large
  /// share as speed: the bunny at toughness 0 gained ×1.19 in 49 steps (session 21).
  /// Writes the shift into `shift` (the body's segment, zero elsewhere) from the body's
  /// Σf (`net`) and 𝒜δ (`mass_delta`).
  void balance_fragments(const CollisionBody& b, Eigen::Ref<const Eigen::VectorXd> net,
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
  BlockJacobi m_blocks;                 ///< small fragments' and projectiles' blocks
  std::vector<BlockJacobi::OuterRows> m_outer_rows;  ///< each row's entries, for the blocks
  /// Large fragments a contact touches: their groups until use_sparse_blocks(), then
  /// their blocks.
  std::vector<std::vector<Eigen::Index>> m_sparse_candidates;
  SparseBlocks m_sparse;
  bool m_sparse_active = false;
  std::vector<Mat3> m_row_terms;        ///< each row's κ n nᵀ (if active) + η (I − n nᵀ)
  /// One row's entry at a node: multiply() adds weight · m_row_forces[row] there.
  struct NodeEntry {
    std::size_t row;
    double weight;
  };
  std::vector<Eigen::Index> m_entry_nodes;      ///< the first rows of the nodes the rows touch
  std::vector<std::size_t> m_node_entry_start;  ///< m_entry_nodes[n]'s entries: [start[n], start[n + 1])
  std::vector<NodeEntry> m_node_entries;
  std::vector<Vec3> m_row_forces;       ///< multiply()'s scratch
  std::vector<bool> m_body_needs_own;   ///< per body: a fragment too large for a block
  Eigen::VectorXd m_in, m_out;  // scratch for the bodies' blocks
  std::vector<Index> m_node_fragment;  // scratch for balance_fragments
  Eigen::VectorXd m_net, m_mass_delta, m_shift;  // momentum_shifts' Σf; apply()'s 𝒜δ and shift
  std::vector<bool> m_touched, m_pinned;
};

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
        m_mass_delta(Eigen::VectorXd::Zero(system.size())) {}

  /// η_k = μ λ_k / |v_t| from the current estimate (lagged Coulomb friction), and the
  /// terms of φ that depend on it.
  void set_friction() {
    m_pull = Eigen::VectorXd::Zero(m_system.size());
    for (std::size_t k = 0; k < m_rows.size(); ++k) {
      Row& row = m_rows[k];
      row.eta = 0.0;
      if (row.friction > 0.0 && row.lambda > 0.0) {
        const double sliding = tangential_part(row, row.free_velocity + m_relative[k]).norm();
        row.eta = std::min(row.friction * row.lambda / std::max(sliding, kStickSpeed),
                           kFrictionPenaltyRatio * row.kappa);
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
    }
    return {violation, unmet};
  }

  [[nodiscard]] const Eigen::VectorXd& delta() const { return m_delta; }
  [[nodiscard]] const std::vector<Vec3>& forces() const { return m_forces; }

 private:
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
                              m_settings.tolerance, m_settings.max_cg_iterations,
                              m_settings.inner_reduction)
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
    if (rows[k].reach > 0.0) allowed[k] = std::min(allowed[k], settings.reach_share * rows[k].reach / settings.dt);
  }
  const bool any_friction = std::any_of(rows.begin(), rows.end(), [](const Row& r) { return r.friction > 0.0; });
  AugmentedLagrangian solver(system, settings);
  const int max_outer = std::max(settings.iterations, any_friction ? 2 : 1);
  if (settings.sparse_blocks_from_start) system.use_sparse_blocks();
  for (int outer = 0; outer < max_outer; ++outer) {
    solver.set_friction();
    const int iterations = solver.step();
    report.cg_iterations += iterations;
    if (iterations > settings.sparse_blocks_after) {
      report.ran_long = true;
      system.use_sparse_blocks();
    }
    ++report.outer_iterations;
    const auto [violation, unmet] = solver.update_multipliers(allowed);
    report.largest_violation = violation;
    // Friction acts from the second iteration on (it needs the normal impulse), so with
    // friction one more solve.
    if (!unmet && (!any_friction || outer >= 1)) break;
  }

  system.apply(solver.delta(), solver.forces(), settings.dt);
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const Index r = system.row_of(k);
    contacts[k].impulse = r == kInvalidIndex ? 0.0 : rows[r].lambda;
  }
  return report;
}

}  // namespace fissure::sim
