#pragma once
/// Through-holes of a cage and of a surface (issue 43, `--keep-holes`): a cage keeps a
/// genus-g surface's holes open when it has at least g of its own, so the two sides
/// of each hole can separate. Counted from Euler characteristics, not sampled.

#include <cstddef>
#include <optional>

#include "common/surface_mesh.h"
#include "common/tet_mesh.h"

namespace fissure::bake {

/// The cage's through-holes: its first Betti number, from the Euler characteristic of
/// its tets (χ = V − E + F − T = pieces − holes + cavities) and the shells of its
/// boundary (pieces + cavities, each shell the boundary faces joined through edges).
/// Exact for a cage whose boundary is a manifold surface; a lattice's cubes meeting
/// only along an edge can make it count one more or one less there.
std::size_t cage_holes(const TetMesh& cage, const CageFaces& faces);

/// The holes of the solid a closed surface bounds: the sum of its components' genus,
/// (2·components − χ) / 2, its vertices joined where they share a position. Nothing
/// for a surface that is open or not a manifold (an edge not shared by two triangles):
/// its holes are not defined.
std::optional<std::size_t> surface_holes(const SurfaceMesh& mesh);

}  // namespace fissure::bake
