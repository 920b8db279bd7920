#pragma once
/// Collision spheres the player makes where a bundle's collision points leave a tet
/// bare.
///
/// The bake culls every sphere whose 26 grid neighbours are all present: such a sphere
/// cannot touch anything while the body is whole (collision_proxies.h). Fracture ends
/// that: a crack through the culled interior exposes tets with no collision point at
/// all, and a fragment made only of them falls through the ground (issue 16: with
/// toughness 0, 197 of the sample bunny's 987 tets had none, and their one-tet fragments
/// fell 0.9 m below the ground in 110 steps; the exact collision mode has the same hole
/// wherever the render surface does not pass; World covers the sphere mode only). So each tet that holds solid but no
/// collision point keeps one sphere in reserve, and gets it the moment one of its faces
/// is exposed: the scene pays nothing while the body is whole and the bundle stays as
/// it was baked.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "player/sim/environment.h"
#include "player/sim/fracture.h"
#include "player/sim/implicit_integrator.h"

namespace fissure::sim {

/// One sphere per tet, at its centroid, as large as fits inside the tet: World's
/// stand-in when a bundle has no baked spheres.
EmbeddedPoints inscribed_spheres(const Matrix3Xd& rest, const Matrix4Xu& tets);

class StandInSpheres {
 public:
  StandInSpheres() = default;
  /// The reserve of every tet that has no point in `points` and holds solid (`mass`'s
  /// fraction above 0; every tet without `mass`). Its sphere sits at the solid's
  /// centre of mass (the centroid without `mass`), as large as fits in the tet there,
  /// scaled by the cube root of the solid fraction.
  StandInSpheres(const Matrix3Xd& rest, const Matrix4Xu& tets, const EmbeddedPoints& points,
                 const MassDistribution* mass);

  /// Appends to `points` the reserve of each tet of `exposed` that still has one, and
  /// spends it. Returns how many it added.
  std::size_t add_for(std::span<const TetFace> exposed, EmbeddedPoints& points);
  /// Removes the points from index `count` on (those added by a step rolled back),
  /// putting their tets' reserves back.
  void truncate(EmbeddedPoints& points, std::size_t count);
  /// Tets that still hold a reserve.
  [[nodiscard]] std::size_t reserved() const;

 private:
  std::vector<Vec4> m_barycentric;  ///< per tet
  std::vector<double> m_radius;     ///< per tet; 0: no reserve (it has points or holds no solid)
  std::vector<std::uint8_t> m_given;  ///< per tet: its reserve is in the points now
};

}  // namespace fissure::sim
