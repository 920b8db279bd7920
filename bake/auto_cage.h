#pragma once
/// Automatic cages (issue 43): a cage made from the render mesh alone, for
/// `fissure-bake cage` and `fissure-bake bake --tets N` without --cage.

#include <cstddef>
#include <string>

#include "common/surface_mesh.h"
#include "common/tet_mesh.h"

namespace fissure::bake {

/// Bump when a change to a method would change its cages: bundles baked on an automatic
/// cage record it, and `status` calls them stale when it differs.
inline constexpr int kAutoCageVersion = 1;

/// The tet counts a user may ask for. Below one cube's 6 tets there is no lattice; above
/// a million the bake that follows would need tens of GB.
inline constexpr std::size_t kMinCageTets = 6;
inline constexpr std::size_t kMaxCageTets = 1'000'000;

struct AutoCageOptions {
  std::string method = "lattice";  ///< "lattice" (lattice_cage.h) or "wrap" (wrap_cage.h)
  std::size_t tets = 0;            ///< asked; 0: no automatic cage (a cage file is given)
  double tolerance = 0.15;         ///< the made count lies within ±tolerance·tets
  /// Keep a closed surface's through-holes open in the cage (at least as many holes as
  /// its genus), or fail naming the count that would: `--keep-holes`. Without it, holes
  /// narrower than a few cells close.
  bool keep_holes = false;
  [[nodiscard]] bool enabled() const { return tets > 0; }
};

struct AutoCage {
  TetMesh mesh;
  std::string method;
  double cell = 0;           ///< lattice: the cube edge; wrap: Mesh_3's cell size [m]
  std::size_t tries = 0;     ///< cell sizes tried by the search
  std::size_t bridge_cubes = 0;
  double seconds = 0;
};

/// `--tets` as typed: a whole number (1000, 1e3) within [kMinCageTets, kMaxCageTets].
/// Throws fissure::Error naming the flag and the value otherwise.
std::size_t parse_tet_count(const std::string& text);

/// Checks the options (throws fissure::Error naming `--tets` or `--method`).
void validate(const AutoCageOptions& options);

/// Makes a cage of about `options.tets` tets around `mesh` (oriented first, as the bake
/// orients it, so inside/outside agrees). Throws fissure::Error naming `mesh_name` for a
/// mesh with no area, a flat mesh, or a count that cannot be met within the tolerance.
/// Lattice: containment by construction (the bake checks it again, check_cage_covers);
/// wrap: checked here, and a wrap that misses part of the surface is remade with 1.5×
/// then 2.25× the clearance before the call fails. With keep_holes, a cage with fewer
/// holes than the surface's genus is an error naming the count that keeps them (lattice)
/// or is wrapped again with a finer envelope (wrap; half, then a quarter of its alpha).
AutoCage make_cage(const SurfaceMesh& mesh, const AutoCageOptions& options, const std::string& mesh_name,
                   double winding_accuracy = 3.0);

}  // namespace fissure::bake
