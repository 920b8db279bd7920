#pragma once
/// Stage "walls" (thesis III.C, improved): class every cage face, and rasterize each
/// face the surface cuts into a tile holding the signed distance to the contour (so a
/// linear-filtered alpha test draws a crisp edge even at low resolution, instead of the
/// thesis's binary alpha and its "small gap" artifacts) and the depth below the outer
/// surface (so the player can bound displacement). Faces wholly inside the solid get no
/// tile: the player draws them with a shared tileable detail material, baked here once.
///
/// Packing: one face per square tile, the face in the half u + v ≤ 1 and the fields
/// continued over the other half. The thesis packs two faces per square (its "ghost
/// point"), which halves the texels but makes the two faces bleed into each other under
/// linear filtering — it had to point-sample. Filtering is what makes a distance field
/// worth storing, so we spend the second half on a clean continuation.

#include <cstddef>
#include <cstdint>

#include "bake/face_regions.h"
#include "bake/surface_distance.h"
#include "common/surface_mesh.h"
#include "formats/bundle.h"

namespace fissure::bake {

struct WallOptions {
  std::uint32_t resolution = 64;        ///< texels per tile side (`--wall-res`)
  double sdf_range_texels = 4.0;        ///< distance saturates at ± this many texels
  std::uint32_t depth_divisor = 4;      ///< depth tiles are resolution / divisor per side (at least 4)
  std::uint32_t detail_resolution = 128;
  std::uint64_t detail_seed = 1;
  std::size_t memory_budget_bytes = std::size_t{1} << 30;  ///< tiles larger than this are an error
  /// The most texel-by-contour-segment distance tests a resolution above the default
  /// may imply (about 15 s); 0: no limit (`--no-work-limit`). The default resolution is
  /// never refused: its work follows from the mesh and the cage, not from a flag.
  std::uint64_t max_work = 2'000'000'000;
};

/// Checks options before any work; throws fissure::Error naming the bad option.
void validate(const WallOptions& options);

/// Bakes the walls of `bundle` (which must hold the embedding). Throws fissure::Error
/// when the tiles would exceed the memory budget.
formats::Walls bake_walls(const formats::Bundle& bundle, const FaceRegions& regions, const WallOptions& options);

/// A lower bound [m] of the distance from every point of the triangle (a, b, c) to the
/// surface (0 when none is positive), within `tolerance` of the true least distance
/// (relative) unless `max_splits` runs out first. Distance to a surface changes no
/// faster than position, so on a piece of the triangle it is at least the least
/// distance at the piece's corners less the smaller of the piece's circumradius and its
/// longest edge (slivers); branch and bound splits
/// the piece with the lowest such bound in four until that bound is within tolerance of
/// its corners' distance. Only the region nearest the surface is refined: tens of
/// nearest-point queries a face, where a uniform lattice as tight would take thousands
/// (and one of 8 steps an edge gave up 1/8 of an edge, most of a typical clearance).
[[nodiscard]] double triangle_clearance(const SurfaceDistance& surface, const Vec3& a, const Vec3& b, const Vec3& c,
                                        double tolerance = 0.1, int max_splits = 400);

/// A tileable height map (gradient noise, 4 octaves, period = resolution) and its
/// normal map: the shared detail of interior walls. Same seed, same bytes.
void bake_detail(std::uint32_t resolution, std::uint64_t seed, std::vector<std::uint8_t>& height,
                 std::vector<std::uint8_t>& normal);


}  // namespace fissure::bake
