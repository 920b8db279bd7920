#pragma once
/// What `fissure-bake cage` reports about a cage, made or hand-made: its size, the
/// shape of its tets (dihedral angles), its pieces, its volume against the solid's and
/// its clearance around the surface.

#include <array>
#include <cstddef>
#include <string>

#include "common/surface_mesh.h"
#include "common/tet_mesh.h"

namespace fissure::bake {

struct CageQuality {
  std::size_t nodes = 0, tets = 0;
  double min_dihedral_deg = 0, max_dihedral_deg = 0;
  /// Dihedral angles (6 per tet) in 10° bins: [0] = [0°, 10°), …, [17] = [170°, 180°].
  std::array<std::size_t, 18> dihedral_histogram{};
  std::size_t degenerate_tets = 0;  ///< non-positive or relatively tiny volume
  std::size_t pieces = 0;           ///< face-connected groups of tets
  double mean_edge = 0;             ///< [m]
  double cage_volume = 0;           ///< [m³]
  double solid_volume = 0;          ///< enclosed by the surface (divergence theorem; open surfaces: approximate)
  /// The smallest distance from a surface vertex to the cage's boundary: how near the
  /// surface comes to the cage's hull (0: it touches it).
  double clearance_min = 0;
  /// The largest distance from a boundary node of the cage to the surface: how far
  /// the cage reaches beyond it.
  double overhang_max = 0;
  std::size_t holes = 0;  ///< the cage's through-holes (cage_topology.h)
  /// The surface's (the sum of its genus), or -1 where it is open and holes are not defined.
  std::ptrdiff_t surface_holes = -1;
};

/// Measures `cage` around `mesh` (the mesh is only used for volume and clearance).
CageQuality measure_cage(const SurfaceMesh& mesh, const TetMesh& cage);

/// Dihedral angles of one tet, in degrees, at its 6 edges.
std::array<double, 6> dihedral_angles_deg(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);

/// Several lines for people: counts, dihedral range and histogram, pieces, volumes,
/// clearance, holes.
std::string quality_text(const CageQuality& quality);
std::string quality_json(const CageQuality& quality);

}  // namespace fissure::bake
