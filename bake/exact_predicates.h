#pragma once
/// Exact geometric predicates on double inputs, for code outside the CGAL translation
/// units (CGAL's filtered predicates behind a CGAL-free header).

namespace fissure::bake {

/// Sign of the 2D orientation of (a, b, c): +1 counter-clockwise, −1 clockwise, 0
/// collinear — exact for any finite double inputs.
int orientation_2d(double ax, double ay, double bx, double by, double cx, double cy);

}  // namespace fissure::bake
