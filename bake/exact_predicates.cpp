// A small CGAL translation unit: only Epick's filtered 2D orientation.
#include "bake/exact_predicates.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

namespace fissure::bake {

int orientation_2d(double ax, double ay, double bx, double by, double cx, double cy) {
  using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_2;
  return static_cast<int>(CGAL::orientation(Point(ax, ay), Point(bx, by), Point(cx, cy)));
}

}  // namespace fissure::bake
