#include "common/surface_mesh.h"

#include <algorithm>
#include <array>
#include <numeric>
#include <vector>

#include "common/union_find.h"

namespace fissure {

double triangle_area(const SurfaceMesh& mesh, TriangleIndex t) {
  const Vec3 a = mesh.positions.col(mesh.triangles(0, t));
  const Vec3 b = mesh.positions.col(mesh.triangles(1, t));
  const Vec3 c = mesh.positions.col(mesh.triangles(2, t));
  return 0.5 * (b - a).cross(c - a).norm();
}

bool is_degenerate(const SurfaceMesh& mesh, TriangleIndex t) {
  const Vec3 a = mesh.positions.col(mesh.triangles(0, t));
  const Vec3 b = mesh.positions.col(mesh.triangles(1, t));
  const Vec3 c = mesh.positions.col(mesh.triangles(2, t));
  const double longest = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
  return !(triangle_area(mesh, t) > 1e-12 * longest);
}

std::vector<Index> position_representatives(const Matrix3Xd& positions) {
  const auto n = static_cast<Index>(positions.cols());
  std::vector<Index> order(n);
  std::iota(order.begin(), order.end(), Index{0});
  auto less = [&](Index a, Index b) {
    for (int k = 0; k < 3; ++k) {
      if (positions(k, a) != positions(k, b)) return positions(k, a) < positions(k, b);
    }
    return a < b;
  };
  std::sort(order.begin(), order.end(), less);
  std::vector<Index> representative(n);
  for (Index i = 0; i < n; ++i) {
    const Index v = order[i];
    const bool same_as_previous = i > 0 && positions.col(order[i - 1]) == positions.col(v);
    representative[v] = same_as_previous ? representative[order[i - 1]] : v;
  }
  return representative;
}

bool bounds_nothing(const SurfaceMesh& mesh, const std::vector<Index>& representatives, TriangleIndex t) {
  const Index a = representatives[mesh.triangles(0, t)], b = representatives[mesh.triangles(1, t)],
              c = representatives[mesh.triangles(2, t)];
  return a == b || b == c || a == c || is_degenerate(mesh, t);
}

SurfaceTopology analyze_topology(const SurfaceMesh& mesh) {
  SurfaceTopology topology;
  const std::vector<Index> rep = position_representatives(mesh.positions);
  std::vector<std::array<Index, 2>> edges;
  edges.reserve(mesh.triangle_count() * 3);
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    const Index a = rep[mesh.triangles(0, t)], b = rep[mesh.triangles(1, t)], c = rep[mesh.triangles(2, t)];
    if (a == b || b == c || a == c || triangle_area(mesh, t) == 0.0) {
      ++topology.degenerate_triangles;
      continue;
    }
    for (auto [u, v] : {std::array<Index, 2>{a, b}, {b, c}, {c, a}}) {
      edges.push_back({std::min(u, v), std::max(u, v)});
    }
  }
  std::sort(edges.begin(), edges.end());

  std::vector<Index> parent(mesh.vertex_count());
  std::iota(parent.begin(), parent.end(), Index{0});
  std::vector<bool> on_boundary(mesh.vertex_count(), false);
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    const std::size_t uses = j - i;
    ++topology.edges;
    if (uses == 1) {
      ++topology.boundary_edges;
      const auto [u, v] = edges[i];
      on_boundary[u] = on_boundary[v] = true;
      parent[find_root(parent, u)] = find_root(parent, v);
    } else if (uses > 2) {
      ++topology.nonmanifold_edges;
    }
    i = j;
  }
  for (Index v = 0; v < mesh.vertex_count(); ++v) {
    if (on_boundary[v] && find_root(parent, v) == v) ++topology.boundary_loops;
  }
  return topology;
}

}  // namespace fissure
