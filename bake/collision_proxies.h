#pragma once
/// Stage "collision" (thesis III.D.2): collision spheres on a per-tet grid, and each
/// tet's exact mass fraction and centre of mass.
///
/// Spheres: a grid of spacing 2r shared by all tets (so neighbours line up across tet
/// boundaries); a tet keeps the grid points inside itself and inside the solid; a
/// non-empty tet that gets fewer than 3 halves r (on the same grid, refined) and
/// rescans, up to `max_halvings` times. Spheres whose 26 grid neighbours are all
/// present (at the same level) can never touch anything and are dropped.
///
/// Mass: the thesis estimates a tet's solid fraction from its spheres; we integrate it
/// exactly instead. The region tet ∩ solid is bounded by the surface clipped to the
/// tet and by the inside regions of the tet's faces; summing signed tetrahedra from the
/// tet's centroid over those outward-oriented boundary triangles gives its volume and
/// first moment (divergence theorem), with no sampling error.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "bake/face_regions.h"
#include "bake/winding_number.h"
#include "formats/bundle.h"

namespace fissure::bake {

/// About 10 s of the collision stage where every tet crosses the surface, and at most
/// ~2 GiB where every tet is inside; the default radius implies ~45 points a tet, so
/// this admits cages of millions of tets. A 12-triangle cube in the 10-tet sample cage
/// at radius 1e-4 (2.3e9 estimated) took 31 s and 500 MB.
inline constexpr std::uint64_t kDefaultMaxGridPoints = 200'000'000;

struct SphereOptions {
  double radius = 0.0;        ///< target radius [m] (`--sphere-radius`); 0: a fifth of the median cage edge
  int max_halvings = 4;       ///< how many times a tet may halve the radius to reach 3 spheres
  bool cull_surrounded = true;  ///< drop spheres whose 26 grid neighbours are all present
  /// The most grid points the radius may imply (estimated_grid_points) before the stage
  /// is refused; 0: no limit (`--no-work-limit`).
  std::uint64_t max_grid_points = kDefaultMaxGridPoints;
};

/// Throws fissure::Error for a negative or non-finite radius or a negative halving count.
void validate(const SphereOptions& options);

/// The grid points the collision stage scans at spacing `spacing` (twice the radius):
/// every tet's bounding box in whole cells. An upper bound of its work, known before it.
double estimated_grid_points(const TetMesh& cage, double spacing);

/// Throws fissure::Error, before any work, when the radius (given, or the default for
/// this cage) implies more grid points than options.max_grid_points, with the estimate
/// and the flag that forces it.
void check_collision_work(const TetMesh& cage, const SphereOptions& options);

/// The radius used when options.radius is 0: a fifth of the cage's median edge length.
double default_sphere_radius(const TetMesh& cage);

struct CollisionStats {
  std::size_t samples_kept = 0;      ///< before culling
  std::size_t culled = 0;            ///< fully surrounded, dropped
  std::size_t tets_halved = 0;       ///< tets that needed a smaller radius
  std::size_t tets_short = 0;        ///< non-empty tets left with fewer than 3 spheres after every halving
};

formats::Collision bake_collision(const formats::Bundle& bundle, const FaceRegions& regions,
                                  const WindingNumberTree& winding, const SphereOptions& options,
                                  CollisionStats* stats = nullptr);

/// Volume [m³] and centroid of tet ∩ solid, integrated exactly from the bundle's
/// embedding and the face regions.
struct SolidPart {
  double volume = 0.0;
  Vec3 centroid = Vec3::Zero();
};
/// `instances` are the embedding's instance indices whose tet is `tet`.
SolidPart solid_part(const formats::Bundle& bundle, const FaceRegions& regions, TetIndex tet,
                     const std::vector<std::size_t>& instances);

}  // namespace fissure::bake
