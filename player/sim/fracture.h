#pragma once
/// Node-splitting fracture (thesis IV.G; O'Brien & Hodgins 1999, snapped to element
/// boundaries as in Parker & O'Brien 2009; docs/architecture.md, "The physics in brief").
///
/// Each tet's world stress is split into tensile and compressive parts by its
/// eigenvalues; each node collects the nodal forces of both parts from its tets, and
///   ς = ½ (−m(Σf⁺) + Σ m(f⁺) + m(Σf⁻) − Σ m(f⁻)),   m(v) = v vᵀ / |v|.
/// Where ς's largest eigenvalue exceeds the toughness, the node splits: the tets whose
/// centroid lies on the positive side of the plane through the node, normal to that
/// eigenvector, move to a new node. Nodes are never removed, and render data never
/// changes: the renderer shows the exposed faces' walls.

#include <span>
#include <utility>
#include <vector>

#include "player/sim/implicit_integrator.h"

namespace fissure::sim {

/// One face of one tet: face k is the one opposite corner k (common/tet_mesh.h order).
struct TetFace {
  TetIndex tet = kInvalidIndex;
  int face = 0;
  friend bool operator==(const TetFace&, const TetFace&) = default;
};

/// What one tet face is, as far as rendering and contacts care.
enum class FaceState : std::uint8_t {
  Interior = 0,      ///< shared with another tet
  RestBoundary = 1,  ///< on the cage's boundary at rest
  Fractured = 2,     ///< shared at rest, split apart since: a wall shows here
};

/// Connectivity of a body as it fractures: which faces are exposed (on the boundary
/// now: never shared at rest, or split apart since) and which fragment (connected
/// component through shared nodes) each tet is in.
class FractureTopology {
 public:
  explicit FractureTopology(const Matrix4Xu& tets, Index node_count);

  /// The (tet, corner) slots that hold `node`, sorted by tet then corner.
  [[nodiscard]] const std::vector<std::pair<TetIndex, int>>& incident(NodeIndex node) const {
    return m_incident[node];
  }
  [[nodiscard]] bool exposed(TetFace f) const { return face_state(f) != FaceState::Interior; }
  [[nodiscard]] FaceState face_state(TetFace f) const { return m_face_state[4 * f.tet + static_cast<Index>(f.face)]; }
  /// 4 per tet, face k opposite corner k.
  [[nodiscard]] const std::vector<FaceState>& face_states() const { return m_face_state; }
  [[nodiscard]] std::size_t exposed_face_count() const { return m_exposed_count; }
  /// The tet that shared face f at rest (tet kInvalidIndex on the rest boundary).
  [[nodiscard]] TetFace rest_neighbour(TetFace f) const { return m_neighbour[4 * f.tet + static_cast<Index>(f.face)]; }

  [[nodiscard]] const std::vector<Index>& tet_fragment() const { return m_fragment; }
  [[nodiscard]] Index fragment_count() const { return m_fragment_count; }
  /// Changes exactly when connectivity does (a split, or its undo): a renderer that
  /// keeps the tets uploads them again only then.
  [[nodiscard]] std::uint64_t version() const { return m_version; }

  /// Records that `moved` slots now hold `added` instead of `node`; appends the faces
  /// this exposed to `newly_exposed`. Fragments are not updated: call update_fragments()
  /// once after a batch of splits.
  void on_split(NodeIndex node, NodeIndex added, std::span<const std::pair<TetIndex, int>> moved,
                const Matrix4Xu& tets, std::vector<TetFace>& newly_exposed);
  /// Undoes the newest on_split; `tets` must already hold `node` again in its slots
  /// (ImplicitIntegrator::undo_split). Call update_fragments() after a batch.
  void undo_split(NodeIndex node, NodeIndex added, const Matrix4Xu& tets);
  /// Recomputes fragment ids (smallest tet index first, so ids are stable and
  /// deterministic). O(#T); returns whether the count changed.
  bool update_fragments(const Matrix4Xu& tets);

 private:
  [[nodiscard]] bool faces_match(TetFace a, TetFace b, const Matrix4Xu& tets) const;

  std::vector<std::vector<std::pair<TetIndex, int>>> m_incident;
  std::vector<TetFace> m_neighbour;      ///< 4 per tet
  std::vector<FaceState> m_face_state;   ///< 4 per tet
  std::size_t m_exposed_count = 0;
  std::vector<Index> m_fragment;
  Index m_fragment_count = 1;
  std::uint64_t m_version = 0;
};

struct FractureSettings {
  double toughness = std::numeric_limits<double>::infinity();  ///< [N]; ∞ never splits, 0 splits any stressed node
  int max_splits_per_step = 64;  ///< bounds the cost of a step (and the pattern rebuild) under extreme loads
};

struct NodeSplit {
  NodeIndex node = kInvalidIndex;   ///< the node that split
  NodeIndex added = kInvalidIndex;  ///< the new node
  Vec3 normal = Vec3::Zero();       ///< fracture plane normal (ς's largest eigenvector)
  double eigenvalue = 0;            ///< ς's largest eigenvalue [N]
  std::vector<TetIndex> moved;      ///< the tets that now hold `added` in `node`'s place (a replay needs them)
};

/// The largest eigenvalue and its eigenvector of every node's separation tensor, from
/// the stresses of the body's last evaluate(…, with_stress = true).
struct SeparationField {
  std::vector<double> eigenvalue;
  std::vector<Vec3> direction;
};
/// With `only_above` > 0, nodes whose separation provably cannot exceed it (an upper
/// bound from the stresses' norms, see fracture.cpp) are skipped and left at eigenvalue
/// 0, direction 0: a body at rest, or stressed far below its toughness, pays only for
/// the bound. Every node above the bound gets the same value as without it.
void separation_field(const ImplicitIntegrator& body, SeparationField& out, double only_above = 0.0);

/// Splits up to max_splits_per_step nodes whose separation exceeds the toughness,
/// largest first (ties by node index), each node at most once per call. Appends the
/// splits and newly exposed faces; updates fragments when anything split.
void fracture(ImplicitIntegrator& body, FractureTopology& topology, const FractureSettings& settings,
              std::vector<NodeSplit>& splits, std::vector<TetFace>& newly_exposed);

}  // namespace fissure::sim
