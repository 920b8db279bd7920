// One of the few translation units that include CGAL (builds are slow; keep it so).
#include "bake/self_intersections.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/intersections.h>
#include <tbb/parallel_reduce.h>
#include <tbb/blocked_range.h>

#include <array>
#include <functional>
#include <utility>
#include <vector>

namespace fissure::bake {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, Index, CGAL::Box_intersection_d::ID_EXPLICIT>;

struct Triangle {
  std::array<Index, 3> rep;  ///< position representatives of the corners
  std::array<Point, 3> point;
};

/// The corners of `b` that are not corners of `a`, and how many are shared.
int shared_corners(const Triangle& a, const Triangle& b, std::array<int, 3>& own_b) {
  int shared = 0, own = 0;
  for (int k = 0; k < 3; ++k) {
    const bool in_a = b.rep[k] == a.rep[0] || b.rep[k] == a.rep[1] || b.rep[k] == a.rep[2];
    if (in_a) {
      ++shared;
    } else {
      own_b[own++] = k;
    }
  }
  return shared;
}

bool intersect(const Triangle& a, const Triangle& b) {
  std::array<int, 3> own_b{}, own_a{};
  const int shared = shared_corners(a, b, own_b);
  shared_corners(b, a, own_a);
  const Kernel::Triangle_3 ta(a.point[0], a.point[1], a.point[2]), tb(b.point[0], b.point[1], b.point[2]);
  switch (shared) {
    case 0:
      return CGAL::do_intersect(ta, tb);
    case 1: {
      // Sharing a corner: they cross if the edge opposite it in either one meets the other.
      const Kernel::Segment_3 ea(a.point[own_a[0]], a.point[own_a[1]]), eb(b.point[own_b[0]], b.point[own_b[1]]);
      return CGAL::do_intersect(ea, tb) || CGAL::do_intersect(eb, ta);
    }
    case 2: {
      // Sharing an edge: they overlap only if folded flat onto the same side of it.
      const Point& p = a.point[own_a[0]];
      const Point& q = b.point[own_b[0]];
      const Point& e0 = a.point[(own_a[0] + 1) % 3];
      const Point& e1 = a.point[(own_a[0] + 2) % 3];
      return CGAL::coplanar(e0, e1, p, q) && CGAL::coplanar_orientation(e0, e1, p, q) == CGAL::POSITIVE;
    }
    default:
      return true;  // the same triangle twice
  }
}

}  // namespace

std::size_t count_self_intersections(const SurfaceMesh& mesh) {
  const std::vector<Index> rep = position_representatives(mesh.positions);
  std::vector<Triangle> triangles;
  std::vector<Box> boxes;
  triangles.reserve(mesh.triangle_count());
  boxes.reserve(mesh.triangle_count());
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    Triangle tri;
    for (int k = 0; k < 3; ++k) {
      const Index v = mesh.triangles(k, static_cast<Eigen::Index>(t));
      tri.rep[k] = rep[v];
      tri.point[k] = Point(mesh.positions(0, v), mesh.positions(1, v), mesh.positions(2, v));
    }
    if (bounds_nothing(mesh, rep, t)) continue;
    boxes.emplace_back(tri.point[0].bbox() + tri.point[1].bbox() + tri.point[2].bbox(), static_cast<Index>(triangles.size()));
    triangles.push_back(tri);
  }
  std::vector<std::pair<Index, Index>> candidates;
  CGAL::box_self_intersection_d(boxes.begin(), boxes.end(),
                                [&](const Box& a, const Box& b) { candidates.emplace_back(a.info(), b.info()); });
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, candidates.size()), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& range, std::size_t count) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          count += intersect(triangles[candidates[i].first], triangles[candidates[i].second]) ? 1 : 0;
        }
        return count;
      },
      std::plus<>());
}

}  // namespace fissure::bake
