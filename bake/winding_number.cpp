#include "bake/winding_number.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

namespace fissure::bake {
namespace {
constexpr Index kLeafSize = 8;
}

WindingNumberTree::WindingNumberTree(const SurfaceMesh& mesh, double accuracy) : m_mesh(mesh), m_accuracy(accuracy) {
  const auto count = static_cast<Index>(mesh.triangle_count());
  m_order.resize(count);
  std::iota(m_order.begin(), m_order.end(), Index{0});
  std::vector<Vec3> centroids(count), area_vectors(count);
  for (Index t = 0; t < count; ++t) {
    const Vec3 a = mesh.positions.col(mesh.triangles(0, t));
    const Vec3 b = mesh.positions.col(mesh.triangles(1, t));
    const Vec3 c = mesh.positions.col(mesh.triangles(2, t));
    centroids[t] = (a + b + c) / 3.0;
    area_vectors[t] = 0.5 * (b - a).cross(c - a);
  }
  m_nodes.reserve(2 * (count / kLeafSize + 1));
  if (count > 0) build(0, count, centroids, area_vectors);
}

Index WindingNumberTree::build(Index first, Index count, const std::vector<Vec3>& centroids,
                               const std::vector<Vec3>& area_vectors) {
  const auto id = static_cast<Index>(m_nodes.size());
  m_nodes.emplace_back();
  Node node;
  node.first = first;
  node.count = count;
  if (count <= kLeafSize) {
    node.box_min = Vec3::Constant(std::numeric_limits<double>::infinity());
    node.box_max = -node.box_min;
    Vec3 weighted = Vec3::Zero();
    node.area_normal.setZero();
    for (Index i = first; i < first + count; ++i) {
      const Index t = m_order[i];
      for (int k = 0; k < 3; ++k) {
        node.box_min = node.box_min.cwiseMin(m_mesh.positions.col(m_mesh.triangles(k, t)));
        node.box_max = node.box_max.cwiseMax(m_mesh.positions.col(m_mesh.triangles(k, t)));
      }
      const double area = area_vectors[t].norm();
      node.area_normal += area_vectors[t];
      weighted += area * centroids[t];
      node.area += area;
    }
    node.center = node.area > 0.0 ? Vec3(weighted / node.area) : Vec3(0.5 * (node.box_min + node.box_max));
    node.second_moment.setZero();
    for (Index i = first; i < first + count; ++i) {
      const Index t = m_order[i];
      node.second_moment += (centroids[t] - node.center) * area_vectors[t].transpose();
    }
  } else {
    // Split at the median centroid along the longest axis of the centroids' box.
    Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (Index i = first; i < first + count; ++i) {
      lo = lo.cwiseMin(centroids[m_order[i]]);
      hi = hi.cwiseMax(centroids[m_order[i]]);
    }
    int axis = 0;
    (hi - lo).maxCoeff(&axis);
    const Index middle = first + count / 2;
    std::nth_element(m_order.begin() + first, m_order.begin() + middle, m_order.begin() + first + count,
                     [&](Index a, Index b) {
                       return centroids[a][axis] != centroids[b][axis] ? centroids[a][axis] < centroids[b][axis] : a < b;
                     });
    node.left = build(first, middle - first, centroids, area_vectors);
    node.right = build(middle, first + count - middle, centroids, area_vectors);
    // Combine the children's moments, re-centred: Σ a (c − p) nᵀ = M_child + (p_child − p) A_childᵀ.
    const Node& l = m_nodes[node.left];
    const Node& r = m_nodes[node.right];
    node.box_min = l.box_min.cwiseMin(r.box_min);
    node.box_max = l.box_max.cwiseMax(r.box_max);
    node.area = l.area + r.area;
    node.area_normal = l.area_normal + r.area_normal;
    node.center = node.area > 0.0 ? Vec3((l.area * l.center + r.area * r.center) / node.area)
                                  : Vec3(0.5 * (node.box_min + node.box_max));
    node.second_moment = l.second_moment + (l.center - node.center) * l.area_normal.transpose() + r.second_moment +
                         (r.center - node.center) * r.area_normal.transpose();
  }
  node.radius = (node.box_max - node.center).cwiseMax(node.center - node.box_min).norm();  // farthest box corner
  m_nodes[id] = node;
  return id;
}

double WindingNumberTree::solid_angle(Index t, const Vec3& q) const {
  // Van Oosterom & Strackee (1983): tan(Ω/2) = det[a b c] / (|a||b||c| + (a·b)|c| + (b·c)|a| + (c·a)|b|).
  const Vec3 a = m_mesh.positions.col(m_mesh.triangles(0, t)) - q;
  const Vec3 b = m_mesh.positions.col(m_mesh.triangles(1, t)) - q;
  const Vec3 c = m_mesh.positions.col(m_mesh.triangles(2, t)) - q;
  const double la = a.norm(), lb = b.norm(), lc = c.norm();
  const double numerator = a.dot(b.cross(c));
  const double denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
  return 2.0 * std::atan2(numerator, denominator);
}

double WindingNumberTree::winding_number(const Vec3& query) const {
  if (m_nodes.empty()) return 0.0;
  double total = 0.0;
  Index stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = m_nodes[stack[--top]];
    const Vec3 offset = node.center - query;
    const double distance = offset.norm();
    if (distance > m_accuracy * node.radius) {
      // Far field. With r = c − q and f(r) = r/|r|³ (Ω = Σ∫ n·f dA), expand f about the
      // cluster centre: Ω ≈ A·f(r) + J(r):M, J = ∂f/∂r = I/|r|³ − 3 r rᵀ/|r|⁵.
      // (Barill et al. also keep the third-order term; the second-order one alone cuts
      // the error of the plain dipole by about a third. Raise β for more accuracy.)
      const double inv3 = 1.0 / (distance * distance * distance);
      const double inv5 = inv3 / (distance * distance);
      total += node.area_normal.dot(offset) * inv3 + node.second_moment.trace() * inv3 -
               3.0 * offset.dot(node.second_moment * offset) * inv5;
    } else if (node.left == kInvalidIndex) {
      for (Index i = node.first; i < node.first + node.count; ++i) total += solid_angle(m_order[i], query);
    } else {
      stack[top++] = node.left;
      stack[top++] = node.right;
    }
  }
  return total / (4.0 * std::numbers::pi);
}

double WindingNumberTree::winding_number_direct(const Vec3& query) const {
  double total = 0.0;
  for (Index t = 0; t < m_mesh.triangle_count(); ++t) total += solid_angle(t, query);
  return total / (4.0 * std::numbers::pi);
}

}  // namespace fissure::bake
