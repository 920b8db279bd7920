#include "bake/auto_cage.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <optional>
#include <stdexcept>

#include "bake/bake.h"
#include "bake/cage_quality.h"
#include "bake/cage_topology.h"
#include "bake/exact_predicates.h"
#include "bake/lattice_cage.h"
#include "bake/surface_orientation.h"
#include "bake/winding_number.h"
#include "bake/wrap_cage.h"
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
  if (options.method != "lattice" && options.method != "wrap") {
    throw Error("--method " + options.method + " is not a cage method", "use --method lattice or --method wrap");
  }
  if (options.tets < kMinCageTets || options.tets > kMaxCageTets) {
    throw Error("--tets " + std::to_string(options.tets) + " is out of range", range_hint());
  }
  if (!(options.tolerance > 0.0 && options.tolerance < 1.0)) throw Error("the cage count tolerance must lie in (0, 1)");
}

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

bool lands(std::size_t made, const AutoCageOptions& options) {
  return made > 0 && std::abs(static_cast<double>(made) / static_cast<double>(options.tets) - 1.0) <= options.tolerance;
}

[[noreturn]] void throw_missed(const std::string& mesh_name, const AutoCageOptions& options, std::size_t nearest,
                               double cell, std::size_t tries) {
  char detail[160];
  std::snprintf(detail, sizeof detail, "the nearest %s cage has %zu tets (cell %.4g), after %zu tries", options.method.c_str(),
                nearest, cell, tries);
  throw Error(mesh_name + ": no " + options.method + " cage lands within ±" +
                  std::to_string(static_cast<int>(options.tolerance * 100 + 0.5)) + " % of --tets " +
                  std::to_string(options.tets) + ": " + detail,
              nearest == 0 ? "ask for fewer tets"
              : nearest > options.tets && options.method == "wrap"
                  ? "the wrap's envelope needs about " + std::to_string(nearest) +
                        " tets at least; ask for more, or use --method lattice for fewer"
                  : "ask for " + std::to_string(nearest) + " tets, or a larger count");
}

std::size_t holes_of(const TetMesh& cage) { return cage_holes(cage, build_cage_faces(cage, "the automatic cage")); }

/// The through-holes the cage must keep: the surface's genus with --keep-holes; none
/// without it, or for an open surface, whose holes are not defined (a warning says so).
std::size_t holes_to_keep(const SurfaceMesh& mesh, const AutoCageOptions& options, const std::string& mesh_name) {
  if (!options.keep_holes) return 0;
  const auto holes = surface_holes(mesh);
  if (!holes) {
    log_warning(mesh_name + ": --keep-holes: the surface is open (or not a manifold), so it has no through-holes to "
                            "count; the cage is made as without it");
    return 0;
  }
  log_debug(mesh_name + ": " + std::to_string(*holes) + " through-holes to keep");
  return *holes;
}

std::string holes_kept(std::size_t kept, std::size_t keep) {
  return "keeps " + std::to_string(kept) + " of the surface's " + std::to_string(keep) + " through-holes open";
}

/// The first of the 27 placements of a grid of cells `cell` (phase ¼, ½ or ¾ of the slack
/// per axis) whose cage keeps `keep` holes and whose count `accept` takes.
template <typename Accept>
std::optional<LatticeCage> placement_keeping_holes(const SurfaceMesh& mesh, const WindingNumberTree& winding, double cell,
                                                   const Vec3& stretch, std::size_t keep, std::size_t& tries,
                                                   const Accept& accept) {
  constexpr double kPhases[3] = {0.5, 0.25, 0.75};
  for (int combo = 0; combo < 27; ++combo) {
    const Vec3 phase(kPhases[combo % 3], kPhases[(combo / 3) % 3], kPhases[combo / 9]);
    LatticeCage lattice = build_lattice_cage(mesh, winding, LatticeGrid{cell, phase, stretch});
    ++tries;
    if (accept(lattice.mesh.tet_count()) && holes_of(lattice.mesh) >= keep) return lattice;
  }
  return std::nullopt;
}

/// Where the searched grid closes a hole, another placement of it, or a cell a few
/// percent larger or smaller, may keep them all and still land near the count.
std::optional<LatticeCage> lattice_keeping_holes(const SurfaceMesh& mesh, const WindingNumberTree& winding,
                                                 const LatticeGrid& found, std::size_t keep, const AutoCageOptions& options,
                                                 std::size_t& tries) {
  for (const double scale : {1.0, 0.97, 0.94, 1.03}) {
    auto lattice = placement_keeping_holes(mesh, winding, found.cell * scale, found.stretch, keep, tries,
                                           [&](std::size_t tets) { return lands(tets, options); });
    if (lattice) return lattice;
  }
  return std::nullopt;
}

/// The lattice closed some of the surface's holes at every placement near the count:
/// cells a tenth smaller at a time, each at every placement, until one keeps them all,
/// so the error can name the count that does.
[[noreturn]] void throw_lattice_closes_holes(const SurfaceMesh& mesh, const WindingNumberTree& winding, LatticeGrid grid,
                                             std::size_t kept, std::size_t keep, const AutoCageOptions& options,
                                             const std::string& mesh_name) {
  std::size_t needed = 0, tries = 0;
  for (int step = 0; step < 30 && needed == 0; ++step) {
    grid.cell *= 0.9;
    bool too_fine = false;
    const auto finer = placement_keeping_holes(mesh, winding, grid.cell, grid.stretch, keep, tries, [&](std::size_t tets) {
      too_fine = too_fine || tets == 0 || tets > kMaxCageTets;
      return !too_fine;
    });
    if (finer) needed = finer->mesh.tet_count();
    if (too_fine) break;
  }
  throw Error(mesh_name + ": --keep-holes: the lattice cage of about " + std::to_string(options.tets) + " tets " +
                  holes_kept(kept, keep) + " (a hole closes where it is narrower than a few cells)",
              needed > 0 ? "the lattice keeps all " + std::to_string(keep) + " at about " + std::to_string(needed) +
                               " tets: ask for --tets " + std::to_string(needed) +
                               " or more, or leave out --keep-holes and let them close"
                         : "no lattice of up to " + std::to_string(kMaxCageTets) +
                               " tets keeps them all; leave out --keep-holes, or make a cage by hand");
}

AutoCage lattice_cage(const SurfaceMesh& mesh, const AutoCageOptions& options, const std::string& mesh_name,
                      double winding_accuracy) {
  const auto start = std::chrono::steady_clock::now();
  const WindingNumberTree winding(mesh, winding_accuracy);
  AutoCage cage;
  cage.method = options.method;
  LatticeGrid grid = search_lattice_grid(mesh, winding, options.tets, options.tolerance, &cage.tries);
  LatticeCage lattice = build_lattice_cage(mesh, winding, grid);
  if (!lands(lattice.mesh.tet_count(), options)) throw_missed(mesh_name, options, lattice.mesh.tet_count(), grid.cell, cage.tries);
  if (const std::size_t keep = holes_to_keep(mesh, options, mesh_name); keep > 0) {
    const std::size_t kept = holes_of(lattice.mesh);
    if (kept < keep) {
      auto other = lattice_keeping_holes(mesh, winding, grid, keep, options, cage.tries);
      if (!other) throw_lattice_closes_holes(mesh, winding, grid, kept, keep, options, mesh_name);
      lattice = std::move(*other);
      grid = lattice.grid;
    }
  }
  cage.mesh = std::move(lattice.mesh);
  cage.cell = grid.cell;
  cage.bridge_cubes = lattice.bridge_cubes;
  cage.seconds = seconds_since(start);
  char line[200];
  std::snprintf(line, sizeof line, "  cage: lattice of %zu cubes (cell %.4g, %zu joining), %zu tets, %zu nodes, %zu tries (%.3f s)",
                lattice.cubes, grid.cell, lattice.bridge_cubes, cage.mesh.tet_count(), cage.mesh.node_count(), cage.tries,
                cage.seconds);
  log_info(line);
  return cage;
}

/// Exude's sliver bound is a target, not a guarantee (the lattice's 45° is): say so
/// when a tet is left below it.
void warn_below_10_degrees(const TetMesh& cage) {
  std::size_t below = 0;
  for (TetIndex t = 0; t < cage.tet_count(); ++t) {
    const auto angles = dihedral_angles_deg(cage.rest_positions.col(cage.tets(0, t)), cage.rest_positions.col(cage.tets(1, t)),
                                            cage.rest_positions.col(cage.tets(2, t)), cage.rest_positions.col(cage.tets(3, t)));
    below += *std::min_element(angles.begin(), angles.end()) < 10.0;
  }
  if (below > 0) {
    log_warning("the wrap cage has " + std::to_string(below) +
                " tets with a dihedral angle below 10° (Mesh_3's exude did not reach its bound); "
                "--method lattice keeps every angle at 45° or more");
  }
}

/// The wrap's envelope, made from the first estimate of the cell, `estimate` (so the
/// search cannot inflate the envelope with the cell and find the count on a balloon: a
/// coarser envelope needing as many tets as a finer one): gaps wider than about two
/// cells stay open, and it stands half a cell out (times `grow` after a miss); both
/// times `fine` where --keep-holes needs narrower holes kept open.
WrapParameters wrap_parameters(double estimate, double grow, double fine) {
  return {2.0 * estimate * fine, grow * estimate * fine / 2.0};
}

/// Mesh_3's boundary keeps within an eighth of the cell of the envelope, and within half
/// its clearance, so the cage cannot cut into the surface by more than Mesh_3's
/// approximation (checked exactly afterwards), and coarser cages follow the surface
/// more loosely, needing fewer tets along it.
double facet_distance(const WrapParameters& wrap, double cell) { return std::min(cell / 8.0, wrap.offset / 2.0); }

/// The cell size at which the wrap's mesh lands nearest the count: secant steps on
/// log(count) against log(cell) (Mesh_3's count falls like cell^-3), unpolished meshes.
double search_wrap_cell(const SurfaceWrap& wrap, const WrapParameters& parameters, double cell,
                        const AutoCageOptions& options, std::size_t& tries) {
  const double asked = static_cast<double>(options.tets);
  double best_cell = cell, best_miss = std::numeric_limits<double>::infinity(), slope = 3.0;
  double last_cell = 0, last_count = 0;
  for (int step = 0; step < 8; ++step) {
    const double count = static_cast<double>(wrap.mesh_at(cell, facet_distance(parameters, cell), false).tet_count());
    ++tries;
    log_debug("wrap: cell " + std::to_string(cell) + ": " + std::to_string(static_cast<std::size_t>(count)) + " tets");
    const double miss = count > 0 ? std::abs(std::log(count / asked)) : std::numeric_limits<double>::infinity();
    if (miss < best_miss) {
      best_miss = miss;
      best_cell = cell;
    }
    if (miss < std::log1p(0.05) || count == 0) break;
    if (last_count > 0 && count != last_count) {
      slope = std::clamp(-std::log(count / last_count) / std::log(cell / last_cell), 1.5, 4.0);
    }
    last_cell = cell;
    last_count = count;
    cell *= std::pow(count / asked, 1.0 / slope);
  }
  return best_cell;
}

/// The wrap cage of about options.tets tets, its envelope's alpha and offset times `fine`
/// (1; ½ and ¼ where --keep-holes needs narrower holes kept open).
AutoCage wrap_cage(const SurfaceMesh& mesh, const AutoCageOptions& options, const std::string& mesh_name, double fine) {
  const auto start = std::chrono::steady_clock::now();
  Vec3 lo = mesh.positions.rowwise().minCoeff(), hi = mesh.positions.rowwise().maxCoeff();
  // A first cell from the box: Mesh_3's tets of circumradius r hold about r³/2 each,
  // and a solid fills roughly a third of its box.
  double estimate = std::cbrt((hi - lo).prod() / 3.0 / (0.5 * static_cast<double>(options.tets)));
  AutoCage cage;
  cage.method = options.method;
  WrapParameters parameters;
  double cell = estimate;
  for (double grow = 1.0;; grow *= 1.5) {
    // A larger clearance makes a larger envelope: the cell is searched again for it.
    // An envelope whose surface alone needs more tets than asked (a thin or detailed
    // shape: the box's estimate is too fine) is made coarser, twice at most.
    for (int coarser = 0;; ++coarser, estimate *= 1.6) {
      parameters = wrap_parameters(estimate, grow, fine);
      const SurfaceWrap wrap(mesh, parameters);
      cell = search_wrap_cell(wrap, parameters, estimate, options, cage.tries);
      cage.mesh = wrap.mesh_at(cell, facet_distance(parameters, cell), true);
      // Not where --keep-holes made the envelope finer: a coarser one would close the holes again.
      const int most_coarser = fine < 1.0 ? 0 : 2;
      if (lands(cage.mesh.tet_count(), options) || cage.mesh.tet_count() < options.tets || coarser == most_coarser) break;
    }
    cage.cell = cell;
    if (!lands(cage.mesh.tet_count(), options)) throw_missed(mesh_name, options, cage.mesh.tet_count(), cell, cage.tries);
    try {
      check_cage_covers(mesh, cage.mesh, mesh_name, "the wrap cage");
      break;
    } catch (const Error& e) {
      if (grow > 2.0) {
        throw Error(mesh_name + ": the wrap cage misses part of the surface even at 2.25× its clearance: " + e.what(),
                    "use --method lattice (it holds the surface by construction), or ask for more tets");
      }
      log_warning(std::string("the wrap cage missed part of the surface; growing its clearance and trying again: ") + e.what());
    }
  }
  warn_below_10_degrees(cage.mesh);
  cage.seconds = seconds_since(start);
  char line[200];
  std::snprintf(line, sizeof line, "  cage: wrap (alpha %.4g, offset %.4g, cell %.4g), %zu tets, %zu nodes, %zu tries (%.3f s)",
                parameters.alpha, parameters.offset, cell, cage.mesh.tet_count(), cage.mesh.node_count(), cage.tries,
                cage.seconds);
  log_info(line);
  return cage;
}

/// The wrap, wrapped again with half and then a quarter of its alpha and offset while it
/// keeps fewer holes than `keep` (the surface's genus, with --keep-holes).
AutoCage wrap_cage_keeping_holes(const SurfaceMesh& mesh, const AutoCageOptions& options, const std::string& mesh_name) {
  const std::size_t keep = holes_to_keep(mesh, options, mesh_name);
  for (double fine = 1.0;; fine /= 2.0) {
    AutoCage cage;
    try {
      cage = wrap_cage(mesh, options, mesh_name, fine);
    } catch (const Error& e) {
      if (fine == 1.0) throw;
      throw Error(mesh_name + ": --keep-holes: a finer wrap (" + (fine == 0.5 ? "half" : "a quarter") +
                      " of its alpha) that might keep the holes could not be made: " + e.what(),
                  "ask for more tets, use --method lattice --keep-holes, or leave out --keep-holes");
    }
    const std::size_t kept = keep > 0 ? holes_of(cage.mesh) : 0;
    if (kept >= keep) return cage;
    if (fine < 0.3) {
      throw Error(mesh_name + ": --keep-holes: the wrap cage of about " + std::to_string(options.tets) + " tets " +
                      holes_kept(kept, keep) + ", even with a quarter of its alpha",
                  "ask for more tets, use --method lattice --keep-holes, or leave out --keep-holes");
    }
    log_info("  the wrap cage " + holes_kept(kept, keep) + "; wrapping again with half its alpha");
  }
}

}  // namespace

AutoCage make_cage(const SurfaceMesh& input, const AutoCageOptions& options, const std::string& mesh_name,
                   double winding_accuracy) {
  validate(options);
  require_solid_extent(input, mesh_name);
  // Inside/outside must agree with the bake's, which orients the surface first.
  SurfaceMesh mesh = input;
  orient_surface(mesh);
  if (options.method != "wrap") return lattice_cage(mesh, options, mesh_name, winding_accuracy);
  try {
    return wrap_cage_keeping_holes(mesh, options, mesh_name);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {  // a CGAL precondition on input it cannot wrap or mesh
    throw Error(mesh_name + ": the wrap cage could not be made: " + e.what(), "use --method lattice for this mesh");
  }
}

}  // namespace fissure::bake
