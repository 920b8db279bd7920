#pragma once
/// Pairs of render triangles that intersect other than along the edge or vertex they
/// share, decided with CGAL's exact predicates. The bake does not need a surface free
/// of them (inside/outside comes from winding numbers), but where the surface crosses
/// itself the winding number reaches 2 or −1, the solid counts overlapping parts
/// once, and the collision-mass check cannot compare the tets' solid with the signed
/// enclosed volume: the bake warns and records the count (formats::Embedding).

#include <cstddef>

#include "common/surface_mesh.h"

namespace fissure::bake {

/// Vertices at bit-identical positions count as one; degenerate triangles are skipped.
/// A duplicated triangle counts as intersecting its copy.
std::size_t count_self_intersections(const SurfaceMesh& mesh);

}  // namespace fissure::bake
