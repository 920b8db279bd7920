#pragma once
/// Collision spheres that reach the render surface (issue 42).
///
/// The grid spheres (collision_proxies.h) have their centres inside the solid on a grid
/// of spacing 2r, so the visible surface lies anywhere from r outside them to a cell
/// inside: on the sample bunny a render vertex sank 5.6 mm into the ground while no
/// sphere sank 0.4 mm. Surface spheres close that gap: the render surface is sampled
/// about once per cell of a grid of spacing r (one sample a cell, the one nearest the
/// cell's centre), and each sample p with outward normal n gets a sphere centred at
/// c = p − r n, so the sphere's lowest point is the surface itself, with radius the
/// distance from c to the surface (≤ r: where the surface curves in, the sphere shrinks
/// so it never pokes out). Where that distance falls below kSurfaceFit r (a part thinner
/// than 2r, a fold) or c is outside, r is halved, up to kSurfaceShrinks times, and the
/// sample dropped after.
///
/// A surface sphere is bound to the tet that holds its surface point, not the one that
/// holds its centre: fracture can free that tet alone, and its spheres must cover what
/// it draws. Its centre may lie outside the tet (within its radius of it); the player
/// follows it with the tet's extrapolated motion, as it does render vertices.

#include <cstddef>
#include <vector>

#include "bake/surface_distance.h"
#include "bake/winding_number.h"
#include "formats/bundle.h"

namespace fissure::bake {

/// How many times a surface sphere may be halved to fit a thin part of the solid.
inline constexpr int kSurfaceShrinks = 2;
/// A surface sphere fits when its centre's distance to the surface is at least this
/// share of the distance to its own sample (it then misses the sample by at most 10 %).
inline constexpr double kSurfaceFit = 0.9;

struct SurfaceSphere {
  TetIndex tet = 0;
  Vec4 barycentric = Vec4::Constant(0.25);  ///< the centre in `tet` (may be outside it)
  double radius = 0;
};

struct SurfaceSphereStats {
  std::size_t spheres = 0;
  std::size_t shrunk = 0;   ///< halved at least once to fit
  std::size_t dropped = 0;  ///< samples that fit no sphere (slivers thinner than r / 2^kSurfaceShrinks)
};

/// The surface spheres of a bundle with its embedding: radius at most `radius`, one per
/// sample cell of `spacing` radii, in a fixed order (by sample cell), whatever the
/// thread count.
std::vector<SurfaceSphere> surface_spheres(const formats::Bundle& bundle, const WindingNumberTree& winding,
                                           const SurfaceDistance& distance, double radius, double spacing,
                                           SurfaceSphereStats* stats = nullptr);

}  // namespace fissure::bake
