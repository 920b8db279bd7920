#pragma once
/// Stage "collision" (thesis III.D.2): collision spheres on a grid and on the render
/// surface, and each tet's exact mass fraction and centre of mass.
///
/// Spheres follow the solid, not the cage (issue 42): the radius comes from the render
/// mesh's size, one grid of spacing 2r is shared by all tets, and each tet keeps the
/// grid points inside itself and inside the solid, however few (the thesis halved r
/// per tet until it had 3, so a finer cage multiplied the spheres: 6,787 on the sample
/// bunny's 987-tet cage, 80,451 on its 10,024-tet one). A tet with solid but no sphere
/// gets a stand-in from the player when fracture exposes it (stand_in_spheres.h).
/// Spheres whose 26 grid neighbours are all present can never touch anything and are
/// dropped; the others shrink so as not to poke out of the surface. Grid spheres fill
/// the solid but leave its surface up to a cell away, so surface spheres
/// (surface_spheres.h) reach the visible surface itself.
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
#include "common/surface_mesh.h"
#include "formats/bundle.h"

namespace fissure::bake {

/// About 10 s of the collision stage where every tet crosses the surface, and at most
/// ~2 GiB where every tet is inside. A 12-triangle cube in the 10-tet sample cage at
/// radius 1e-4 (2.3e9 estimated) took 31 s and 500 MB.
inline constexpr std::uint64_t kDefaultMaxGridPoints = 200'000'000;

/// The sphere model, recorded in the bake options ("sphere_version") so that `status`
/// reports bundles baked with another as stale. 1 (no key): a fifth of the median cage
/// edge, halved per tet to 3 spheres; 2: the radius from the solid, one grid, surface
/// spheres (issue 42); 3: and reserve spheres (surface_spheres.h, reserve_spheres).
inline constexpr int kSphereVersion = 3;

/// A render vertex gets a reserve sphere when no sphere of its own tet passes within
/// this share of the radius of it (docs/decisions/0076).
inline constexpr double kReserveGapShare = 0.5;

/// The default radius is this share of the cube root of the solid's volume: 4.1 mm on
/// the 15 cm sample bunny (0.754 l), about the 4.16 mm the 987-tet cage's median edge
/// gave it before.
inline constexpr double kRadiusPerSize = 0.045;

/// A grid sphere shrinks to its centre's distance from the surface, and is dropped
/// below this share of the radius.
inline constexpr double kLeastGridShare = 0.25;

struct SphereOptions {
  double radius = 0.0;        ///< target radius [m] (`--sphere-radius`); 0: default_sphere_radius of the mesh
  bool cull_surrounded = true;  ///< drop spheres whose 26 grid neighbours are all present
  /// Surface spheres (surface_spheres.h) one per cell of this many radii
  /// (`--surface-spacing`); 0: none. The trade, on the sample's 12 variants: 2 against 1
  /// takes the collision phase to 0.67× and a pile's contacts to a fifth, and lets the
  /// deepest render vertex sink 14 mm against 9.5; at 1 a body carries 2.6× the spheres,
  /// and 64 bodies piled in one place took 19.6 s for 40 steps against 4.6 s at 2
  /// (docs/decisions/0070).
  double surface_spacing = 2.0;
  /// The most grid points the radius may imply (estimated_grid_points) before the stage
  /// is refused; 0: no limit (`--no-work-limit`).
  std::uint64_t max_grid_points = kDefaultMaxGridPoints;
};

/// Throws fissure::Error for a negative or non-finite radius.
void validate(const SphereOptions& options);

/// The grid points the collision stage scans at spacing `spacing` (twice the radius):
/// every tet's bounding box in whole cells. An upper bound of its work, known before it.
double estimated_grid_points(const TetMesh& cage, double spacing);

/// Throws fissure::Error, before any work, when the radius (given, or the default for
/// this mesh) implies more grid points than options.max_grid_points, with the estimate
/// and the flag that forces it.
void check_collision_work(const SurfaceMesh& mesh, const TetMesh& cage, const SphereOptions& options);

/// The radius used when options.radius is 0: kRadiusPerSize times the cube root of the
/// volume the mesh encloses, or of a twentieth of its bounding box diagonal cubed where
/// that is larger (an open or flat mesh encloses little), whatever the cage.
double default_sphere_radius(const SurfaceMesh& mesh);

struct CollisionStats {
  std::size_t samples_kept = 0;    ///< grid points inside the solid, before culling
  std::size_t culled = 0;          ///< fully surrounded, dropped
  std::size_t near_surface = 0;    ///< grid spheres dropped: under kLeastGridShare r from the surface
  std::size_t surface = 0;         ///< surface spheres
  std::size_t surface_shrunk = 0;  ///< surface spheres made smaller to fit a thin part
  std::size_t tets_bare = 0;       ///< tets with solid but no sphere (the player's stand-ins cover them)
  std::size_t reserve = 0;         ///< reserve spheres (surface_spheres.h, reserve_spheres)
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
