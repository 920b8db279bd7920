#pragma once
/// The lattice cage (issue 43): a regular grid of cubes over the mesh's bounding box,
/// each cube split into the 6 Kuhn (Freudenthal) tets around its main diagonal, trimmed
/// to the cubes the surface touches or whose centre is inside the solid. PhysX's voxel
/// simulation mesh and the thesis's first control mesh are built the same way.
///
/// Properties that hold by construction, not by luck:
/// - containment: a cube is kept whenever the closed surface triangle and the closed
///   cube share a point (an exact test on the cube's own double corners), and the
///   kept cubes' tets tile exactly those cubes, so every surface point is in the cage;
/// - quality: every tet is congruent to the Kuhn simplex of a cube, dihedral angles
///   45° (twice), 60° and 90° (three times): the minimum is 45° at any cell size (39.2°
///   where the search had to stretch the cells, see kLatticeStretches);
/// - conformity: every cube uses the same diagonal, so neighbouring cubes' faces match;
/// - one piece per connected part: cubes meeting only along an edge or at a corner are
///   joined by the cubes between them, so the cage is face-connected wherever the
///   kept cubes touch at all;
/// - determinism: the result depends only on the mesh and the cell size, never on the
///   thread count (parallel loops write per-index results that are merged in order).

#include <cstddef>

#include "common/surface_mesh.h"
#include "common/tet_mesh.h"

namespace fissure::bake {

class WindingNumberTree;

/// Where the grid lies: cells of edge `cell` (times `stretch` per axis: 1 for cubes),
/// with `phase` (0…1, per axis) of the slack between the grid and the mesh's bounding
/// box below the box (½: centred).
struct LatticeGrid {
  double cell = 0;
  Vec3 phase = Vec3::Constant(0.5);
  Vec3 stretch = Vec3::Ones();
};

/// The stretches the search may use where no cubic grid lands near the count (a small
/// count of a symmetric shape moves in steps of several cubes): each axis 0.9, 1 or 1.1
/// times the cell, so the tets' dihedral angles stay within 39.2° … 90° (45° … 90° for cubes).
inline constexpr double kLatticeStretches[3] = {1.0, 0.9, 1.1};

struct LatticeCage {
  TetMesh mesh;
  LatticeGrid grid;
  std::size_t cubes = 0;          ///< kept cubes (6 tets each)
  std::size_t surface_cubes = 0;  ///< of those, touched by the surface
  std::size_t bridge_cubes = 0;   ///< added to join cubes meeting only at an edge or corner
};

/// Grids finer than this many cubes (bounding box included) are refused: the search
/// stops there, rather than run out of memory on a needle-thin or huge request.
inline constexpr std::size_t kMaxLatticeGridCubes = std::size_t{1} << 24;

/// The number of cubes the trimmed lattice of `grid` keeps, without building it; 0 when
/// the grid would exceed kMaxLatticeGridCubes. `winding` is the surface's tree.
std::size_t count_lattice_cubes(const SurfaceMesh& mesh, const WindingNumberTree& winding, const LatticeGrid& grid);

/// The trimmed, joined lattice cage of `grid`. The mesh must have a non-degenerate
/// triangle and not lie in one plane (make_cage checks).
LatticeCage build_lattice_cage(const SurfaceMesh& mesh, const WindingNumberTree& winding, const LatticeGrid& grid);

/// The cell size whose cage lands nearest `tets` (within `tolerance`, relative, when
/// any does): a secant search on the log of the cell size, then bisection between the
/// sizes that bracket the count, then other placements of the grid, then stretched
/// cells (small counts move in steps of whole cubes). Deterministic.
LatticeGrid search_lattice_grid(const SurfaceMesh& mesh, const WindingNumberTree& winding, std::size_t tets,
                                double tolerance, std::size_t* tries = nullptr);

}  // namespace fissure::bake
