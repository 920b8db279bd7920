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

/// How many times a reserve sphere may be halved to come within its miss of a vertex
/// (r / 256: 16 µm on the sample bunny).
inline constexpr int kReserveShrinks = 8;

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

struct ReserveSphere {
  SurfaceSphere sphere;
  /// The tet of the sphere (of `c`) that covers the vertex while its tet is joined to
  /// it, the nearest within the gap; kInvalidIndex where none does.
  TetIndex cover_tet = kInvalidIndex;
};

/// Reserve spheres (issue 42). The player moves each render vertex with the tet it is
/// deepest inside (formats::vertex_instances), and a one-tet fragment has only that
/// tet's spheres; a vertex covered by a sphere of a neighbouring tet (its cell's sample
/// fell there) is bare once a crack parts the two. On the sample a one-tet chip rested
/// with a corner 14 mm in the ground, 18 mm from its tet's two spheres. So each vertex
/// that no sphere of its own tet (those of `c`, then the reserve made before it, in
/// vertex order) passes within `gap` of gets one: touching the surface at the vertex
/// from inside along its normal (fit as the surface spheres, up to `radius`), halved
/// until its surface passes within gap / 2 of the vertex. The player holds one back
/// until a split parts its tet from its cover tet (stand_in_spheres.h). A vertex no
/// sphere fits stays bare.
std::vector<ReserveSphere> reserve_spheres(const formats::Bundle& b, const formats::Collision& c,
                                           const WindingNumberTree& winding, const SurfaceDistance& distance,
                                           double radius, double gap);

}  // namespace fissure::bake
