#pragma once
/// Repeated triangles: the same three corners listed again (an OBJ that lists its faces
/// twice, a glTF node instanced many times at one place, STL copies). Each copy adds
/// nothing to the surface but costs every later stage; thousands of copies of a cube
/// made the topology stage run out of memory (issue 46). They are dropped, with a count.

#include <cstddef>

#include "common/surface_mesh.h"

namespace fissure::bake {

/// Removes every triangle whose corners are at the same positions, in the same
/// orientation, as an earlier triangle's; keeps the first of each. A triangle and its
/// reverse both stay (together they are a two-sided sheet). Vertices are kept as they
/// are. Returns how many triangles were removed.
std::size_t remove_repeated_triangles(SurfaceMesh& mesh);

}  // namespace fissure::bake
