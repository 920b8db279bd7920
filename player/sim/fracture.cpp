#include "player/sim/fracture.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <numeric>
#include <tbb/blocked_range.h>

#include "common/assert.h"
#include "common/tet_mesh.h"
#include "common/union_find.h"
#include "player/sim/lanes.h"

namespace fissure::sim {

namespace {

std::array<Index, 3> sorted_face(const Matrix4Xu& tets, TetFace f) {
  std::array<Index, 3> nodes{};
  for (int k = 0; k < 3; ++k) nodes[static_cast<std::size_t>(k)] = tets(kTetFaceNodes[f.face][k], f.tet);
  std::sort(nodes.begin(), nodes.end());
  return nodes;
}

/// m(v) = v vᵀ / |v| (0 for v = 0), eq. 4.9.
Mat3 outer_over_norm(const Vec3& v) {
  const double norm = v.norm();
  return norm > 0.0 ? Mat3(v * v.transpose() / norm) : Mat3::Zero();
}

}  // namespace

FractureTopology::FractureTopology(const Matrix4Xu& tets, Index node_count)
    : m_incident(node_count), m_neighbour(4 * static_cast<std::size_t>(tets.cols())),
      m_face_state(4 * static_cast<std::size_t>(tets.cols()), FaceState::RestBoundary), m_fragment(static_cast<std::size_t>(tets.cols()), 0) {
  const auto tet_count = static_cast<TetIndex>(tets.cols());
  for (TetIndex t = 0; t < tet_count; ++t) {
    for (int corner = 0; corner < 4; ++corner) m_incident[tets(corner, t)].emplace_back(t, corner);
  }
  // Rest adjacency: sort every face by its node triple; equal neighbours share it.
  std::vector<std::pair<std::array<Index, 3>, TetFace>> faces;
  faces.reserve(m_neighbour.size());
  for (TetIndex t = 0; t < tet_count; ++t) {
    for (int k = 0; k < 4; ++k) faces.emplace_back(sorted_face(tets, {t, k}), TetFace{t, k});
  }
  std::sort(faces.begin(), faces.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first < b.first : a.second.tet < b.second.tet;
  });
  for (std::size_t i = 0; i + 1 < faces.size(); ++i) {
    if (faces[i].first != faces[i + 1].first) continue;
    const TetFace a = faces[i].second, b = faces[i + 1].second;
    m_neighbour[4 * a.tet + static_cast<Index>(a.face)] = b;
    m_neighbour[4 * b.tet + static_cast<Index>(b.face)] = a;
    m_face_state[4 * a.tet + static_cast<Index>(a.face)] = FaceState::Interior;
    m_face_state[4 * b.tet + static_cast<Index>(b.face)] = FaceState::Interior;
  }
  m_exposed_count =
      static_cast<std::size_t>(std::count(m_face_state.begin(), m_face_state.end(), FaceState::RestBoundary));
  update_fragments(tets);
}

bool FractureTopology::faces_match(TetFace a, TetFace b, const Matrix4Xu& tets) const {
  return sorted_face(tets, a) == sorted_face(tets, b);
}

void FractureTopology::on_split(NodeIndex node, NodeIndex added, std::span<const std::pair<TetIndex, int>> moved,
                                const Matrix4Xu& tets, std::vector<TetFace>& newly_exposed) {
  if (m_incident.size() <= added) m_incident.resize(static_cast<std::size_t>(added) + 1);
  auto& from = m_incident[node];
  for (const auto& slot : moved) {
    from.erase(std::find(from.begin(), from.end(), slot));
    m_incident[added].push_back(slot);
  }
  // Only faces through the split node can change: a face between a moved and a
  // staying tet now has different nodes on its two sides.
  for (const auto& [t, corner] : moved) {
    for (int k = 0; k < 4; ++k) {
      if (k == corner) continue;  // the face opposite the node does not contain it
      const TetFace face{t, k};
      const Index slot = 4 * t + static_cast<Index>(k);
      if (m_face_state[slot] != FaceState::Interior) continue;
      const TetFace other = m_neighbour[slot];
      if (faces_match(face, other, tets)) continue;
      m_face_state[slot] = FaceState::Fractured;
      m_face_state[4 * other.tet + static_cast<Index>(other.face)] = FaceState::Fractured;
      m_exposed_count += 2;
      newly_exposed.push_back(face);
      newly_exposed.push_back(other);
    }
  }
  ++m_version;
}

void FractureTopology::undo_split(NodeIndex node, NodeIndex added, const Matrix4Xu& tets) {
  FISSURE_ASSERT(added + 1 == m_incident.size());
  const std::vector<std::pair<TetIndex, int>> moved = std::move(m_incident[added]);
  m_incident.pop_back();
  // Both lists are sorted (the constructor fills them in tet order and splits keep
  // it), so the merge puts every slot back where it was.
  auto& slots = m_incident[node];
  const auto middle = static_cast<std::ptrdiff_t>(slots.size());
  slots.insert(slots.end(), moved.begin(), moved.end());
  std::inplace_merge(slots.begin(), slots.begin() + middle, slots.end());
  // A fractured face whose two sides share their nodes again was opened by this split:
  // faces never rejoin otherwise, as every split gives one side a new node.
  for (const auto& [t, corner] : moved) {
    for (int k = 0; k < 4; ++k) {
      const Index slot = 4 * t + static_cast<Index>(k);
      if (k == corner || m_face_state[slot] != FaceState::Fractured) continue;
      const TetFace other = m_neighbour[slot];
      if (!faces_match({t, k}, other, tets)) continue;
      m_face_state[slot] = FaceState::Interior;
      m_face_state[4 * other.tet + static_cast<Index>(other.face)] = FaceState::Interior;
      m_exposed_count -= 2;
    }
  }
  --m_version;
}

bool FractureTopology::update_fragments(const Matrix4Xu& tets) {
  // Union-find over tets through shared nodes: two tets that still share a node are
  // still attached (they hinge), so they are one fragment.
  const auto tet_count = static_cast<Index>(tets.cols());
  std::vector<Index> parent(tet_count);
  std::iota(parent.begin(), parent.end(), Index{0});
  for (const auto& slots : m_incident) {
    if (slots.size() < 2) continue;
    // The node's tets joined one by one to the root of those before: that root moves
    // whenever a smaller one joins. Kept fixed, a later tet re-pointed the old root and
    // cut it from what it had just joined: tets sharing a node got different ids (a 4×4×3
    // pile at toughness 0 had 2 such nodes by its 8th step).
    Index joined = find_root(parent, slots.front().first);
    for (std::size_t i = 1; i < slots.size(); ++i) {
      const Index root = find_root(parent, slots[i].first);
      if (root == joined) continue;
      parent[std::max(root, joined)] = std::min(root, joined);
      joined = std::min(root, joined);
    }
  }
  std::vector<Index> id(tet_count, kInvalidIndex);
  Index count = 0;
  for (Index t = 0; t < tet_count; ++t) {
    const Index root = find_root(parent, t);
    if (id[root] == kInvalidIndex) id[root] = count++;
    m_fragment[t] = id[root];
  }
  const bool changed = count != m_fragment_count;
  m_fragment_count = count;
  return changed;
}

void separation_field(const ImplicitIntegrator& body, SeparationField& out, double only_above) {
  const ElementBuffers& elements = body.elements();
  const CorotatedElasticity& elasticity = body.elasticity();
  const std::size_t tet_count = elasticity.tet_count();
  FISSURE_ASSERT(elements.stress.size() == tet_count);
  const Index node_count = body.node_count();
  const Matrix4Xu& tets = elasticity.tets();
  // Which nodes can exceed `only_above`. m(v) is positive semi-definite with largest
  // eigenvalue |v|, so λmax(ς) ≤ ½ (Σ |f⁺ᵢ| + Σ |f⁻ᵢ|), and |f±ᵢ| = V |σ± Q gᵢ| ≤
  // V ‖σ‖_F |gᵢ|: the bound Σ V ‖σ‖_F |gᵢ| over the node's slots. A node below it
  // cannot exceed `only_above`, so skipping it changes no split; the nodes kept are
  // computed exactly as before.
  std::vector<char> needed(node_count, 1);
  if (only_above > 0.0) {
    std::vector<double> bound(node_count, 0.0);
    for (std::size_t t = 0; t < tet_count; ++t) {
      const auto tet = static_cast<TetIndex>(t);
      const double scale = elasticity.rest_volume(tet) * elements.stress[t].norm();
      for (int i = 0; i < 4; ++i) {
        bound[tets(i, static_cast<Eigen::Index>(t))] += scale * elasticity.shape_gradients(tet).col(i).norm();
      }
    }
    // The margin covers the rounding of the bound's own sums.
    const double threshold = only_above * (1.0 - 1e-9);
    for (NodeIndex n = 0; n < node_count; ++n) needed[n] = bound[n] > threshold ? 1 : 0;
  }
  const auto tet_needed = [&](std::size_t t) {
    for (int i = 0; i < 4; ++i) {
      if (needed[tets(i, static_cast<Eigen::Index>(t))] != 0) return true;
    }
    return false;
  };
  // Per tet: the tensile and compressive nodal forces (parallel, one slot per tet).
  std::vector<Mat34> tensile(tet_count), compressive(tet_count);
  parallel_for_range<std::size_t>(tet_count, 512, [&](const auto& range) {
    for (std::size_t t = range.begin(); t != range.end(); ++t) {
      if (!tet_needed(t)) continue;
      Eigen::SelfAdjointEigenSolver<Mat3> eigen;
      eigen.computeDirect(elements.stress[t]);
      Mat3 positive = Mat3::Zero();
      for (int k = 0; k < 3; ++k) {
        const double value = eigen.eigenvalues()[k];
        if (value > 0.0) positive += value * eigen.eigenvectors().col(k) * eigen.eigenvectors().col(k).transpose();
      }
      const Mat3 negative = elements.stress[t] - positive;
      // f_i = −V σ_world (Q gᵢ): the same split as the elastic forces, in world axes.
      const double volume = elasticity.rest_volume(static_cast<TetIndex>(t));
      const Mat34& gradients = elements.rotated_gradients[t];
      tensile[t] = -volume * positive * gradients;
      compressive[t] = -volume * negative * gradients;
    }
  });
  // Per node, in tet order so the sums do not depend on the thread count.
  std::vector<Vec3> sum_tensile(node_count, Vec3::Zero()), sum_compressive(node_count, Vec3::Zero());
  std::vector<Mat3> tensor(node_count, Mat3::Zero());
  for (std::size_t t = 0; t < tet_count; ++t) {
    for (int i = 0; i < 4; ++i) {
      const NodeIndex n = tets(i, static_cast<Eigen::Index>(t));
      if (needed[n] == 0) continue;
      sum_tensile[n] += tensile[t].col(i);
      sum_compressive[n] += compressive[t].col(i);
      tensor[n] += outer_over_norm(tensile[t].col(i)) - outer_over_norm(compressive[t].col(i));
    }
  }
  out.eigenvalue.assign(node_count, 0.0);
  out.direction.assign(node_count, Vec3::Zero());
  for (NodeIndex n = 0; n < node_count; ++n) {
    if (needed[n] == 0) continue;
    const Mat3 separation =
        0.5 * (tensor[n] - outer_over_norm(sum_tensile[n]) + outer_over_norm(sum_compressive[n]));
    Eigen::SelfAdjointEigenSolver<Mat3> eigen;
    eigen.computeDirect(separation);
    out.eigenvalue[n] = eigen.eigenvalues()[2];  // ascending order
    out.direction[n] = eigen.eigenvectors().col(2);
  }
}

void fracture(ImplicitIntegrator& body, FractureTopology& topology, const FractureSettings& settings,
              std::vector<NodeSplit>& splits, std::vector<TetFace>& newly_exposed) {
  if (settings.max_splits_per_step <= 0 || !(settings.toughness < std::numeric_limits<double>::infinity())) return;
  SeparationField field;
  separation_field(body, field, settings.toughness);
  std::vector<NodeIndex> candidates;
  for (NodeIndex n = 0; n < field.eigenvalue.size(); ++n) {
    if (field.eigenvalue[n] > settings.toughness && topology.incident(n).size() > 1) candidates.push_back(n);
  }
  std::sort(candidates.begin(), candidates.end(), [&](NodeIndex a, NodeIndex b) {
    return field.eigenvalue[a] != field.eigenvalue[b] ? field.eigenvalue[a] > field.eigenvalue[b] : a < b;
  });
  const Matrix4Xu& tets = body.elasticity().tets();
  int done = 0;
  std::vector<std::pair<TetIndex, int>> positive_side;
  for (const NodeIndex node : candidates) {
    if (done >= settings.max_splits_per_step) break;
    const Vec3 normal = field.direction[node];
    const Vec3 origin = body.positions().col(node);
    positive_side.clear();
    for (const auto& slot : topology.incident(node)) {
      Vec3 centroid = Vec3::Zero();
      for (int i = 0; i < 4; ++i) centroid += 0.25 * body.positions().col(tets(i, slot.first));
      if (normal.dot(centroid - origin) > 0.0) positive_side.push_back(slot);
    }
    // All tets on one side: the plane does not separate anything at this node.
    if (positive_side.empty() || positive_side.size() == topology.incident(node).size()) continue;
    const NodeIndex added = body.split_node(node, positive_side);
    topology.on_split(node, added, positive_side, body.elasticity().tets(), newly_exposed);
    NodeSplit& split = splits.emplace_back(NodeSplit{node, added, normal, field.eigenvalue[node], {}});
    for (const auto& slot : positive_side) split.moved.push_back(slot.first);
    ++done;
  }
  if (done > 0) topology.update_fragments(body.elasticity().tets());
}

}  // namespace fissure::sim
