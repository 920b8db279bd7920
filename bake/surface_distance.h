#pragma once
/// Unsigned distance from points to the render surface (CGAL AABB tree), for the
/// walls' "how deep is this texel" channel. CGAL stays inside surface_distance.cpp.

#include <memory>

#include "common/surface_mesh.h"

namespace fissure::bake {

class SurfaceDistance {
 public:
  explicit SurfaceDistance(const SurfaceMesh& mesh);
  ~SurfaceDistance();
  SurfaceDistance(const SurfaceDistance&) = delete;
  SurfaceDistance& operator=(const SurfaceDistance&) = delete;

  /// Distance [m] from p to the nearest point of the surface. Thread-safe.
  [[nodiscard]] double distance(const Vec3& p) const;
  /// The same, starting the search from `closest` when `have_closest` (the closest
  /// surface point of a neighbouring query); `closest` then receives p's closest point.
  [[nodiscard]] double distance(const Vec3& p, Vec3& closest, bool have_closest) const;

 private:
  struct Tree;
  std::unique_ptr<Tree> m_tree;
};

}  // namespace fissure::bake
