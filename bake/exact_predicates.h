#pragma once
/// Exact geometric predicates on double inputs, for code outside the CGAL translation
/// units (CGAL's filtered predicates behind a CGAL-free header).

#include "common/types.h"

namespace fissure::bake {

/// Sign of the 2D orientation of (a, b, c): +1 counter-clockwise, −1 clockwise, 0
/// collinear — exact for any finite double inputs.
int orientation_2d(double ax, double ay, double bx, double by, double cx, double cy);

/// Whether the closed triangle (a, b, c) and the closed axis-aligned box [lo, hi] share
/// a point, exactly. A degenerate triangle is tested as the segment (or point) it is.
bool triangle_meets_box(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& lo, const Vec3& hi);

/// Whether the points all lie in one plane (or on one line, or at one point), exactly.
bool all_coplanar(const Matrix3Xd& points);

}  // namespace fissure::bake
