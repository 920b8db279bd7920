// A small CGAL translation unit: Epick's filtered predicates behind exact_predicates.h.
#include "bake/exact_predicates.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/intersections.h>

namespace fissure::bake {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;

Point to_point(const Vec3& p) { return {p.x(), p.y(), p.z()}; }

}  // namespace

int orientation_2d(double ax, double ay, double bx, double by, double cx, double cy) {
  using Point2 = Kernel::Point_2;
  return static_cast<int>(CGAL::orientation(Point2(ax, ay), Point2(bx, by), Point2(cx, cy)));
}

bool triangle_meets_box(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& lo, const Vec3& hi) {
  const Kernel::Iso_cuboid_3 box(to_point(lo), to_point(hi));
  const Point p[3] = {to_point(a), to_point(b), to_point(c)};
  if (!CGAL::collinear(p[0], p[1], p[2])) return CGAL::do_intersect(Kernel::Triangle_3(p[0], p[1], p[2]), box);
  // A collinear triangle is the segment between its two farthest-apart corners:
  // the pair whose segment contains the third corner.
  for (int i = 0; i < 3; ++i) {
    const Point& s = p[(i + 1) % 3];
    const Point& t = p[(i + 2) % 3];
    if (s == t) continue;
    if (CGAL::collinear_are_ordered_along_line(s, p[i], t)) return CGAL::do_intersect(Kernel::Segment_3(s, t), box);
  }
  return !box.has_on_unbounded_side(p[0]);  // all three corners at one point
}

bool all_coplanar(const Matrix3Xd& points) {
  const Eigen::Index n = points.cols();
  if (n < 4) return true;
  // Find three points that span a plane; then every other point must lie in it.
  const Point first = to_point(points.col(0));
  Eigen::Index second = 1;
  while (second < n && to_point(points.col(second)) == first) ++second;
  if (second == n) return true;
  const Point q = to_point(points.col(second));
  Eigen::Index third = second + 1;
  while (third < n && CGAL::collinear(first, q, to_point(points.col(third)))) ++third;
  if (third == n) return true;
  const Point r = to_point(points.col(third));
  for (Eigen::Index i = 0; i < n; ++i) {
    if (CGAL::orientation(first, q, r, to_point(points.col(i))) != CGAL::COPLANAR) return false;
  }
  return true;
}

}  // namespace fissure::bake
