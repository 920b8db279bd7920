#include "player/render/shapes.h"

#include <cmath>
#include <numbers>

namespace fissure::render {

PlainMesh unit_sphere(int rings, int segments) {
  PlainMesh mesh;
  for (int r = 0; r <= rings; ++r) {
    const double theta = std::numbers::pi * r / rings;
    for (int s = 0; s <= segments; ++s) {
      const double phi = 2.0 * std::numbers::pi * s / segments;
      const auto x = static_cast<float>(std::sin(theta) * std::cos(phi)),
                 y = static_cast<float>(std::sin(theta) * std::sin(phi)), z = static_cast<float>(std::cos(theta));
      mesh.positions.insert(mesh.positions.end(), {x, y, z});
      mesh.normals.insert(mesh.normals.end(), {x, y, z});
    }
  }
  const auto at = [&](int r, int s) { return static_cast<std::uint32_t>(r * (segments + 1) + s); };
  for (int r = 0; r < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      mesh.triangles.insert(mesh.triangles.end(), {at(r, s), at(r + 1, s), at(r + 1, s + 1)});
      mesh.triangles.insert(mesh.triangles.end(), {at(r, s), at(r + 1, s + 1), at(r, s + 1)});
    }
  }
  return mesh;
}

}  // namespace fissure::render
