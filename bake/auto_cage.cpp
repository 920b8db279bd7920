#include "bake/auto_cage.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "bake/exact_predicates.h"
#include "bake/lattice_cage.h"
#include "bake/surface_orientation.h"
#include "bake/winding_number.h"
#include "common/error.h"
#include "common/log.h"

namespace fissure::bake {
namespace {

/// The mesh must enclose some volume for a cage to mean anything: at least one
/// triangle with area, and not every vertex in one plane (exactly).
void require_solid_extent(const SurfaceMesh& mesh, const std::string& mesh_name) {
  if (mesh.triangle_count() == 0) {
    throw Error(mesh_name + ": the mesh has no triangles, so there is nothing to cage",
                "check the file exports faces, not only points or lines");
  }
  bool any_area = false;
  for (Index t = 0; t < mesh.triangle_count() && !any_area; ++t) any_area = !is_degenerate(mesh, t);
  if (!any_area) throw Error(mesh_name + ": every triangle of the mesh has zero area, so there is nothing to cage");
  Matrix3Xd used(3, mesh.triangles.size());
  for (Eigen::Index i = 0; i < mesh.triangles.size(); ++i) used.col(i) = mesh.positions.col(mesh.triangles.data()[i]);
  if (all_coplanar(used)) {
    throw Error(mesh_name + ": the mesh is flat (every vertex lies in one plane), so it bounds no volume to simulate",
                "give it thickness (solidify it in the modelling tool), or make a cage by hand with --cage");
  }
}

std::string range_hint() {
  return "ask for " + std::to_string(kMinCageTets) + " … " + std::to_string(kMaxCageTets) +
         " tets; a few hundred to a few thousand suit most scenes";
}

}  // namespace

std::size_t parse_tet_count(const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(value) || value != std::floor(value)) {
    throw Error("--tets " + quote_from_file(text) + " is not a whole number of tets", range_hint());
  }
  if (value < static_cast<double>(kMinCageTets) || value > static_cast<double>(kMaxCageTets)) {
    throw Error("--tets " + text + " is out of range", range_hint());
  }
  return static_cast<std::size_t>(value);
}

void validate(const AutoCageOptions& options) {
  if (options.method != "lattice") {
    throw Error("--method " + options.method + " is not a cage method", "use --method lattice");
  }
  if (options.tets < kMinCageTets || options.tets > kMaxCageTets) {
    throw Error("--tets " + std::to_string(options.tets) + " is out of range", range_hint());
  }
  if (!(options.tolerance > 0.0 && options.tolerance < 1.0)) throw Error("the cage count tolerance must lie in (0, 1)");
}

AutoCage make_cage(const SurfaceMesh& input, const AutoCageOptions& options, const std::string& mesh_name,
                   double winding_accuracy) {
  validate(options);
  require_solid_extent(input, mesh_name);
  const auto start = std::chrono::steady_clock::now();
  // Inside/outside must agree with the bake's, which orients the surface first.
  SurfaceMesh mesh = input;
  orient_surface(mesh);
  const WindingNumberTree winding(mesh, winding_accuracy);
  AutoCage cage;
  cage.method = options.method;
  const LatticeGrid grid = search_lattice_grid(mesh, winding, options.tets, options.tolerance, &cage.tries);
  LatticeCage lattice = build_lattice_cage(mesh, winding, grid);
  const double made = static_cast<double>(lattice.mesh.tet_count());
  const double asked = static_cast<double>(options.tets);
  if (lattice.mesh.tet_count() == 0 || std::abs(made / asked - 1.0) > options.tolerance) {
    char detail[160];
    std::snprintf(detail, sizeof detail, "the nearest lattice has %zu tets (cell %.4g), after %zu tries",
                  lattice.mesh.tet_count(), grid.cell, cage.tries);
    throw Error(mesh_name + ": no lattice cage lands within ±" + std::to_string(static_cast<int>(options.tolerance * 100 + 0.5)) +
                    " % of --tets " + std::to_string(options.tets) + ": " + detail,
                lattice.mesh.tet_count() == 0 ? "ask for fewer tets"
                                              : "ask for " + std::to_string(lattice.mesh.tet_count()) + " tets, or a larger count");
  }
  cage.mesh = std::move(lattice.mesh);
  cage.cell = grid.cell;
  cage.bridge_cubes = lattice.bridge_cubes;
  cage.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  char line[200];
  std::snprintf(line, sizeof line, "  cage: lattice of %zu cubes (cell %.4g, %zu joining), %zu tets, %zu nodes, %zu tries (%.3f s)",
                lattice.cubes, grid.cell, lattice.bridge_cubes, cage.mesh.tet_count(), cage.mesh.node_count(), cage.tries,
                cage.seconds);
  log_info(line);
  return cage;
}

}  // namespace fissure::bake
