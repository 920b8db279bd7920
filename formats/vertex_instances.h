#pragma once
/// Which tet moves each render vertex: the rule the player draws and measures by
/// (docs/decisions/0071-render-vertex-follows-the-tet-that-holds-it.md) and the bake
/// covers with spheres (bake/surface_spheres.h, reserve_spheres).

#include <cstddef>
#include <limits>
#include <vector>

#include "formats/bundle.h"

namespace fissure::formats {

inline constexpr std::size_t kNoInstance = std::numeric_limits<std::size_t>::max();

struct VertexInstance {
  std::size_t instance = kNoInstance;  ///< kNoInstance: no triangle uses the vertex
  int corner = 0;                      ///< the vertex's corner in the instance's triangle
};

/// Per render vertex, the embedding instance that moves it: of the instances of its
/// triangles, the one whose tet it is deepest inside (largest least barycentric
/// coordinate; the first such in instance order). A vertex's triangles are drawn in
/// every tet they cross, each clipped to it, so the vertex is drawn only by the tets
/// that hold it. The vertex's barycentric coordinates in that tet are the instance's
/// column `corner`.
std::vector<VertexInstance> vertex_instances(const Bundle& bundle);

}  // namespace fissure::formats
