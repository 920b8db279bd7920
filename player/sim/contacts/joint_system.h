#pragma once
/// The contact response's joint system (contact_response.cpp's internals, not an API):
/// every body and projectile a contact touches as one vector of unknowns, the contact
/// rows G that read a side's point velocity from it, the operator
/// 𝒜 + Σ_active κ n nᵀ ⊗ G + friction, its block-Jacobi preconditioner, and the final
/// application of the correction with its momentum shifts.

#include <array>
#include <span>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "player/sim/block_jacobi.h"
#include "player/sim/contacts/contact.h"
#include "player/sim/contacts/contact_settings.h"
#include "player/sim/sparse_blocks.h"

namespace fissure::sim::contact_detail {

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
  bool projectile = false;  ///< a side is a projectile

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
inline Vec3 tangential_part(const Row& row, const Vec3& v) { return v - row.normal.dot(v) * row.normal; }

class JointSystem {
 public:
  /// `settings` must outlive this.
  JointSystem(std::span<CollisionBody> bodies, std::span<Projectile> projectiles,
              std::span<const ContactConstraint> contacts, const ContactSettings& settings);

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
  bool use_sparse_blocks();
  std::vector<Row>& rows() { return m_rows; }
  [[nodiscard]] const std::vector<Row>& rows() const { return m_rows; }

  /// Per dense block: whether no tet joins it to another block or to a free node outside
  /// the blocks, so that its block is all of 𝒜 its nodes see. Small fragments are
  /// always sealed while the bodies' fragment ids match their tets; a block that is not
  /// is left to the augmented Lagrangian, which sees the whole operator.
  [[nodiscard]] std::vector<bool> sealed_groups() const;
  /// The dense blocks of 𝒜 alone (no contact terms), factored.
  const BlockJacobi& factor_base_blocks();
  [[nodiscard]] const BlockJacobi& blocks() const { return m_blocks; }
  /// Each row's κ, and the blocks' pairs of rows that update_blocks() fills: only the
  /// augmented Lagrangian needs them, so it asks before its first iteration.
  void set_penalties();
  [[nodiscard]] Index row_of(std::size_t contact) const { return m_contact_row[contact]; }
  /// Body bi's first row among the unknowns, or −1 if no contact moves it.
  [[nodiscard]] Eigen::Index body_offset(std::size_t bi) const { return m_body_offset[bi]; }

  /// y = (𝒜 + Σ_active κ n nᵀ ⊗ G + Σ η Gᵀ T G) x. Each row's force in parallel, then
  /// each node's share of them in row order: the sums a serial pass over the rows makes,
  /// whatever the thread count.
  void multiply(const Eigen::VectorXd& x, Eigen::VectorXd& y);

  /// y = 𝒜 x: the bodies' systems and the projectiles' masses, without the contacts.
  void multiply_mass(const Eigen::VectorXd& x, Eigen::VectorXd& y);

  /// The dense blocks (small fragments, projectiles) exactly, contacts included, and the
  /// sparse ones once made; the bodies' own preconditioners on the rest until then (a
  /// body needs its own only while no sparse block is made: use_sparse_blocks()). The
  /// own one sees no row of a dense block (those are zeroed on the way in), so together
  /// they stay symmetric.
  void precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z);

  /// The blocks of the current operator: the base (system and masses) plus each row's
  /// terms between entries in one block. A large sparse block keeps the factor of the
  /// first outer iteration that made it (SparseBlocks::kKeptFactorNodes): the contacts
  /// turned on or off and the friction since then make it stale, which costs CG
  /// iterations, fewer than its factorizations did.
  void update_blocks();

  /// Applies the correction: bodies move by it (the fragments it touched rigidly
  /// shifted so that together they gain exactly the impulses they received),
  /// projectiles take exactly their impulses.
  void apply(const Eigen::VectorXd& delta, const std::vector<Vec3>& forces, double h);
  /// Applies a correction that already gains exactly the impulses `forces` (sequential
  /// impulses: each dense block's δ is its inverse times its impulses, each rigid group's
  /// carries them as a rigid body's), with no momentum shift: the shift would be rounding,
  /// and finding it costs a product with every touched body's whole system. Projectiles
  /// take their impulses as in apply().
  void apply_exact(const Eigen::VectorXd& delta, const std::vector<Vec3>& forces, double h);

  /// What apply() adds to a correction δ whose 𝒜δ is `mass_delta`, for the contact
  /// forces `forces`: on each body, the rigid shift of balance_fragments on the nodes it
  /// moves; on each projectile, the velocity that makes it gain exactly its own impulses
  /// (apply() gives a projectile Σf / m and ignores its δ). Also leaves Σf in m_net.
  void momentum_shifts(const Eigen::VectorXd& mass_delta, const std::vector<Vec3>& forces, Eigen::VectorXd& shift);

 private:
  /// m_node_fragment = each node's fragment (after a split a node is in one); returns
  /// the number of fragments.
  Index map_node_fragments(const CollisionBody& b);

  /// One dense block per fragment with at most ContactSettings::dense_fragment_nodes
  /// free nodes that a contact touches (a whole small body counts as one fragment) and
  /// per projectile; their base values: the mass terms and the fragment's tets' system
  /// blocks.
  void build_blocks();

  /// The nodes the rows touch, and each one's entries in the rows in row order
  /// (multiply()'s second pass).
  void build_node_entries();

  /// Per fragment of body bi (m_node_fragment): whether a contact row has an entry on it.
  std::vector<bool> fragments_in_contact(std::size_t bi, Index fragments) const;

  /// Body bi's small fragments as groups of their free nodes' rows, in node order.
  void add_fragment_groups(std::size_t bi, std::vector<std::vector<Eigen::Index>>& groups,
                           std::vector<std::vector<Eigen::Index>>& sparse_groups);

  /// Body bi's system A on `blocks` (dense or sparse): each covered node's mass term,
  /// and each covered tet's blocks between its free corners.
  template <typename Blocks>
  void add_fragment_systems(std::size_t bi, Blocks& blocks);

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
                         Eigen::Ref<const Eigen::VectorXd> mass_delta, Eigen::Ref<Eigen::VectorXd> shift);

  /// out = op(in) on each body's block: the body's own system product or preconditioner.
  void for_each_body_block(const Eigen::VectorXd& in, Eigen::VectorXd& out,
                           void (ImplicitIntegrator::*op)(const Eigen::VectorXd&, Eigen::VectorXd&));

  /// Adds a side's entries to the row; returns whether the side can move.
  bool add_side(const ContactSide& s, double sign, Row& row) const;
  /// Σᵢ wᵢ² / (nᵀ Aᵢᵢ n) over the side's free nodes, Aᵢᵢ clamped to
  /// [1, ContactSettings::max_stiffness_share] times the lumped mass: the point's inverse
  /// mass as the system's diagonal sees it.
  [[nodiscard]] double penalty_inverse_mass(const ContactSide& s, const Vec3& normal) const;

  [[nodiscard]] Vec3 velocity(const ContactSide& s) const;

  std::span<CollisionBody> m_bodies;
  std::span<Projectile> m_projectiles;
  std::span<const ContactConstraint> m_contacts;
  const ContactSettings& m_settings;
  bool m_penalties_set = false;
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
  std::vector<Eigen::Index> m_left_out;  ///< first rows of the small fragments no contact touches
  Eigen::VectorXd m_in, m_out;  // scratch for the bodies' blocks
  std::vector<Index> m_node_fragment;  // scratch for balance_fragments
  Eigen::VectorXd m_net, m_mass_delta, m_shift;  // momentum_shifts' Σf; apply()'s 𝒜δ and shift
  std::vector<bool> m_touched, m_pinned;
};

}  // namespace fissure::sim::contact_detail
