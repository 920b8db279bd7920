#include "bake/cage_topology.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <numeric>
#include <utility>
#include <vector>

#include "common/union_find.h"

namespace fissure::bake {
namespace {

using Edge = std::pair<Index, Index>;

Edge edge_of(Index a, Index b) { return a < b ? Edge{a, b} : Edge{b, a}; }

/// Every edge once, sorted, with the number of faces (or tets) it came from.
std::vector<std::pair<Edge, std::size_t>> count_edges(std::vector<Edge> edges) {
  std::sort(edges.begin(), edges.end());
  std::vector<std::pair<Edge, std::size_t>> counted;
  for (const Edge& e : edges) {
    if (counted.empty() || counted.back().first != e) counted.push_back({e, 0});
    ++counted.back().second;
  }
  return counted;
}

/// Components of the items (faces), two items joined when they share an edge.
std::size_t edge_connected(const std::vector<std::pair<Edge, Index>>& item_edges, std::size_t items) {
  std::vector<Index> parent(items);
  std::iota(parent.begin(), parent.end(), Index{0});
  for (std::size_t i = 1; i < item_edges.size(); ++i) {
    if (item_edges[i].first == item_edges[i - 1].first) {
      parent[find_root(parent, item_edges[i].second)] = find_root(parent, item_edges[i - 1].second);
    }
  }
  std::size_t components = 0;
  for (Index i = 0; i < items; ++i) components += find_root(parent, i) == i;
  return components;
}

/// Each face's three edges, tagged with the face, sorted by edge.
std::vector<std::pair<Edge, Index>> face_edges(const Matrix3Xu& faces, const std::vector<Index>& which,
                                               const std::vector<Index>& vertex) {
  std::vector<std::pair<Edge, Index>> out;
  for (Index i = 0; i < which.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      out.push_back({edge_of(vertex[faces(k, which[i])], vertex[faces((k + 1) % 3, which[i])]), i});
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

std::size_t cage_holes(const TetMesh& cage, const CageFaces& faces) {
  std::vector<Edge> edges;
  std::vector<std::uint8_t> used(cage.node_count(), 0);
  for (TetIndex t = 0; t < cage.tet_count(); ++t) {
    for (int i = 0; i < 4; ++i) {
      used[cage.tets(i, t)] = 1;
      for (int j = i + 1; j < 4; ++j) edges.push_back(edge_of(cage.tets(i, t), cage.tets(j, t)));
    }
  }
  const auto vertices = static_cast<std::ptrdiff_t>(std::count(used.begin(), used.end(), 1));
  const auto euler = vertices - static_cast<std::ptrdiff_t>(count_edges(std::move(edges)).size()) +
                     static_cast<std::ptrdiff_t>(faces.face_count()) - static_cast<std::ptrdiff_t>(cage.tet_count());
  std::vector<Index> boundary, identity(cage.node_count());
  std::iota(identity.begin(), identity.end(), Index{0});
  for (FaceIndex f = 0; f < faces.face_count(); ++f) {
    if (faces.is_boundary(f)) boundary.push_back(f);
  }
  const auto shells = static_cast<std::ptrdiff_t>(edge_connected(face_edges(faces.nodes, boundary, identity), boundary.size()));
  return static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, shells - euler));
}

std::optional<std::size_t> surface_holes(const SurfaceMesh& mesh) {
  // Vertices at one position are one vertex: a UV seam does not open the surface.
  std::map<std::array<double, 3>, Index> at;
  std::vector<Index> vertex(mesh.vertex_count());
  for (Index v = 0; v < mesh.vertex_count(); ++v) {
    const auto [it, fresh] = at.emplace(std::array<double, 3>{mesh.positions(0, v), mesh.positions(1, v), mesh.positions(2, v)},
                                        static_cast<Index>(at.size()));
    vertex[v] = it->second;
  }
  std::vector<Index> all(mesh.triangle_count());
  std::iota(all.begin(), all.end(), Index{0});
  const auto edges = face_edges(mesh.triangles, all, vertex);
  std::vector<Edge> plain;
  for (const auto& e : edges) plain.push_back(e.first);
  const auto counted = count_edges(std::move(plain));
  for (const auto& [edge, count] : counted) {
    if (count != 2) return std::nullopt;  // open (1) or non-manifold (3 or more)
  }
  std::vector<std::uint8_t> used(at.size(), 0);
  for (Eigen::Index i = 0; i < mesh.triangles.size(); ++i) used[vertex[mesh.triangles.data()[i]]] = 1;
  const auto vertices = static_cast<std::ptrdiff_t>(std::count(used.begin(), used.end(), 1));
  const auto euler = vertices - static_cast<std::ptrdiff_t>(counted.size()) + static_cast<std::ptrdiff_t>(mesh.triangle_count());
  const auto components = static_cast<std::ptrdiff_t>(edge_connected(edges, all.size()));
  return static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, (2 * components - euler) / 2));
}

}  // namespace fissure::bake
