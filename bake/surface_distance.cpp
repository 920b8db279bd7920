// A CGAL translation unit: the AABB tree behind SurfaceDistance.
#include "bake/surface_distance.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <cmath>
#include <vector>

namespace fissure::bake {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Triangle = Kernel::Triangle_3;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, std::vector<Triangle>::const_iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

struct SurfaceDistance::Tree {
  std::vector<Triangle> triangles;
  fissure::bake::Tree tree;
};

SurfaceDistance::SurfaceDistance(const SurfaceMesh& mesh) : m_tree(std::make_unique<Tree>()) {
  auto point = [&](Index v) { return Kernel::Point_3(mesh.positions(0, v), mesh.positions(1, v), mesh.positions(2, v)); };
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    const Triangle triangle(point(mesh.triangles(0, t)), point(mesh.triangles(1, t)), point(mesh.triangles(2, t)));
    if (!triangle.is_degenerate()) m_tree->triangles.push_back(triangle);
  }
  m_tree->tree.insert(m_tree->triangles.begin(), m_tree->triangles.end());
  m_tree->tree.accelerate_distance_queries();
}

SurfaceDistance::~SurfaceDistance() = default;

double SurfaceDistance::distance(const Vec3& p) const {
  if (m_tree->triangles.empty()) return 0.0;
  return std::sqrt(m_tree->tree.squared_distance(Kernel::Point_3(p.x(), p.y(), p.z())));
}

double SurfaceDistance::distance(const Vec3& p, Vec3& closest, bool have_closest) const {
  if (m_tree->triangles.empty()) return 0.0;
  const Kernel::Point_3 query(p.x(), p.y(), p.z());
  const Kernel::Point_3 found = have_closest ? m_tree->tree.closest_point(query, Kernel::Point_3(closest.x(), closest.y(), closest.z()))
                                             : m_tree->tree.closest_point(query);
  closest = Vec3(found.x(), found.y(), found.z());
  return (p - closest).norm();
}

}  // namespace fissure::bake
