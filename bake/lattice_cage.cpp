#include "bake/lattice_cage.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "bake/exact_predicates.h"
#include "bake/winding_number.h"
#include "common/union_find.h"

namespace fissure::bake {
namespace {

enum CubeFlag : std::uint8_t { kDropped = 0, kSurface = 1, kInside = 2, kBridge = 3 };

/// The grid's planes: x[a][i] for i = 0…n[a], computed once, so every test and every
/// cage node uses the same doubles (the exactness of containment rests on it).
struct Grid {
  std::array<std::vector<double>, 3> x;
  std::array<std::size_t, 3> n{};

  [[nodiscard]] std::size_t cube_count() const { return n[0] * n[1] * n[2]; }
  [[nodiscard]] std::size_t cube(std::size_t i, std::size_t j, std::size_t k) const { return (k * n[1] + j) * n[0] + i; }
  [[nodiscard]] std::array<std::size_t, 3> coords(std::size_t c) const {
    return {c % n[0], (c / n[0]) % n[1], c / (n[0] * n[1])};
  }
  [[nodiscard]] Vec3 corner(const std::array<std::size_t, 3>& c) const { return {x[0][c[0]], x[1][c[1]], x[2][c[2]]}; }
};

/// The surface's bounding box: every vertex a triangle uses.
void surface_box(const SurfaceMesh& mesh, Vec3& lo, Vec3& hi) {
  lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  hi = -lo;
  for (Eigen::Index i = 0; i < mesh.triangles.size(); ++i) {
    const Vec3 p = mesh.positions.col(mesh.triangles.data()[i]);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
}

/// False when the grid would have more than kMaxLatticeGridCubes cubes.
bool make_grid(const Vec3& lo, const Vec3& hi, const LatticeGrid& spec, Grid& grid) {
  const Vec3 size = spec.cell * spec.stretch;
  double cubes = 1.0;
  for (int a = 0; a < 3; ++a) cubes *= std::floor((hi[a] - lo[a]) / size[a]) + 1.0;
  if (!(cubes <= static_cast<double>(kMaxLatticeGridCubes))) return false;
  for (int a = 0; a < 3; ++a) {
    const double extent = hi[a] - lo[a];
    const double slack = (std::floor(extent / size[a]) + 1.0) * size[a] - extent;
    double origin = lo[a] - slack * spec.phase[a];
    if (!(origin <= lo[a])) origin = lo[a] - 0.5 * size[a];
    auto& x = grid.x[static_cast<std::size_t>(a)];
    x.assign(1, origin);
    // Planes until the last is at or past the box (rounding may need one more).
    while (x.back() < hi[a]) x.push_back(origin + static_cast<double>(x.size()) * size[a]);
    if (x.size() < 2) x.push_back(origin + size[a]);
    grid.n[static_cast<std::size_t>(a)] = x.size() - 1;
  }
  return true;
}

/// The cubes along one axis whose closed extent meets [lo, hi]: first and last index.
std::array<std::size_t, 2> cube_range(const std::vector<double>& x, double lo, double hi) {
  const auto first = static_cast<std::size_t>(std::lower_bound(x.begin() + 1, x.end(), lo) - x.begin()) - 1;
  const auto last = static_cast<std::size_t>(std::upper_bound(x.begin(), x.end() - 1, hi) - x.begin()) - 1;
  return {first, last};
}

/// kSurface on every cube a closed triangle meets (exactly), in parallel over chunks of
/// triangles whose hits are merged afterwards: a set, the same for any thread count.
void mark_surface_cubes(const SurfaceMesh& mesh, const Grid& grid, std::vector<std::uint8_t>& flags) {
  constexpr Index kChunk = 1024;
  const Index chunks = (static_cast<Index>(mesh.triangle_count()) + kChunk - 1) / kChunk;
  std::vector<std::vector<std::size_t>> hits(chunks);
  tbb::parallel_for(Index{0}, chunks, [&](Index chunk) {
    const Index end = std::min<Index>(static_cast<Index>(mesh.triangle_count()), (chunk + 1) * kChunk);
    for (Index t = chunk * kChunk; t < end; ++t) {
      const Vec3 a = mesh.positions.col(mesh.triangles(0, t)), b = mesh.positions.col(mesh.triangles(1, t)),
                 c = mesh.positions.col(mesh.triangles(2, t));
      const Vec3 lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
      std::array<std::array<std::size_t, 2>, 3> range;
      for (std::size_t k = 0; k < 3; ++k) range[k] = cube_range(grid.x[k], lo[static_cast<Eigen::Index>(k)], hi[static_cast<Eigen::Index>(k)]);
      if (range[0][0] == range[0][1] && range[1][0] == range[1][1] && range[2][0] == range[2][1]) {
        // Its box lies in one closed cube (the common case for a fine mesh): so does the triangle.
        hits[chunk].push_back(grid.cube(range[0][0], range[1][0], range[2][0]));
        continue;
      }
      for (std::size_t z = range[2][0]; z <= range[2][1]; ++z) {
        for (std::size_t y = range[1][0]; y <= range[1][1]; ++y) {
          for (std::size_t x = range[0][0]; x <= range[0][1]; ++x) {
            if (triangle_meets_box(a, b, c, grid.corner({x, y, z}), grid.corner({x + 1, y + 1, z + 1}))) {
              hits[chunk].push_back(grid.cube(x, y, z));
            }
          }
        }
      }
    }
  });
  for (const auto& list : hits) {
    for (const std::size_t cube : list) flags[cube] = kSurface;
  }
}

/// kInside on every cube the surface misses whose centre has winding number ≥ ½.
void mark_inside_cubes(const WindingNumberTree& winding, const Grid& grid, std::vector<std::uint8_t>& flags) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, flags.size(), 64), [&](const auto& range) {
    for (std::size_t c = range.begin(); c != range.end(); ++c) {
      if (flags[c] != kDropped) continue;
      const auto ijk = grid.coords(c);
      const Vec3 centre = 0.5 * (grid.corner(ijk) + grid.corner({ijk[0] + 1, ijk[1] + 1, ijk[2] + 1}));
      if (winding.winding_number(centre) >= 0.5) flags[c] = kInside;
    }
  });
}

/// Union-find over the grid's cubes, for which kept cubes are face-connected.
class CubePieces {
 public:
  explicit CubePieces(std::size_t cubes) : m_parent(cubes) {
    for (std::size_t c = 0; c < cubes; ++c) m_parent[c] = static_cast<Index>(c);
  }
  void join(std::size_t a, std::size_t b) { m_parent[root(a)] = root(b); }
  [[nodiscard]] bool joined(std::size_t a, std::size_t b) { return root(a) == root(b); }

 private:
  Index root(std::size_t c) { return find_root(m_parent, static_cast<Index>(c)); }
  std::vector<Index> m_parent;
};

/// The cube at `ijk` + `d`, or nothing when that lies outside the grid.
std::optional<std::size_t> offset_cube(const Grid& grid, const std::array<std::size_t, 3>& ijk, const std::array<int, 3>& d) {
  std::array<std::size_t, 3> at{};
  for (std::size_t a = 0; a < 3; ++a) {
    const auto v = static_cast<std::ptrdiff_t>(ijk[a]) + d[a];
    if (v < 0 || v >= static_cast<std::ptrdiff_t>(grid.n[a])) return std::nullopt;
    at[a] = static_cast<std::size_t>(v);
  }
  return grid.cube(at[0], at[1], at[2]);
}

/// Joins kept cubes that meet only along an edge or at a corner through the cubes on a
/// monotone path between them (kBridge), so that the kept cubes that touch at all form
/// one face-connected piece. One pass in cube order: each join is recorded at once in
/// the union-find, so later pairs of the same two pieces add nothing.
void bridge_diagonal_neighbours(const Grid& grid, std::vector<std::uint8_t>& flags) {
  CubePieces pieces(flags.size());
  for (std::size_t c = 0; c < flags.size(); ++c) {
    if (flags[c] == kDropped) continue;
    for (const std::array<int, 3>& d : {std::array<int, 3>{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}) {
      const auto next = offset_cube(grid, grid.coords(c), d);
      if (next && flags[*next] != kDropped) pieces.join(c, *next);
    }
  }
  for (std::size_t c = 0; c < flags.size(); ++c) {
    if (flags[c] == kDropped) continue;
    const auto ijk = grid.coords(c);
    for (int code = 0; code < 27; ++code) {
      const std::array<int, 3> d{code % 3 - 1, (code / 3) % 3 - 1, code / 9 - 1};
      if ((d[0] != 0) + (d[1] != 0) + (d[2] != 0) < 2) continue;  // itself or a face neighbour
      const auto other = offset_cube(grid, ijk, d);
      if (!other || flags[*other] == kDropped || pieces.joined(c, *other)) continue;
      // Step along x, then y, then z: every cube on the way is a face neighbour of the last.
      std::array<int, 3> walked{0, 0, 0};
      std::size_t previous = c;
      for (std::size_t a = 0; a < 3; ++a) {
        if (d[a] == 0) continue;
        walked[a] = d[a];
        const std::size_t step = *offset_cube(grid, ijk, walked);
        if (flags[step] == kDropped) flags[step] = kBridge;
        pieces.join(previous, step);
        previous = step;
      }
    }
  }
}

/// The trimmed and joined cube flags of a grid.
std::vector<std::uint8_t> trim(const SurfaceMesh& mesh, const WindingNumberTree& winding, const Grid& grid) {
  std::vector<std::uint8_t> flags(grid.cube_count(), kDropped);
  mark_surface_cubes(mesh, grid, flags);
  mark_inside_cubes(winding, grid, flags);
  bridge_diagonal_neighbours(grid, flags);
  return flags;
}

/// The kept cubes' corners as nodes (numbered in grid order) and 6 Kuhn tets per cube.
TetMesh lattice_tets(const Grid& grid, const std::vector<std::uint8_t>& flags) {
  const std::array<std::size_t, 3> nodes_per{grid.n[0] + 1, grid.n[1] + 1, grid.n[2] + 1};
  auto node_id = [&](const std::array<std::size_t, 3>& c) { return (c[2] * nodes_per[1] + c[1]) * nodes_per[0] + c[0]; };
  std::vector<Index> dense(nodes_per[0] * nodes_per[1] * nodes_per[2], kInvalidIndex);
  for (std::size_t c = 0; c < flags.size(); ++c) {
    if (flags[c] == kDropped) continue;
    const auto ijk = grid.coords(c);
    for (std::size_t corner = 0; corner < 8; ++corner) {
      dense[node_id({ijk[0] + (corner & 1), ijk[1] + ((corner >> 1) & 1), ijk[2] + ((corner >> 2) & 1)})] = 0;
    }
  }
  TetMesh cage;
  std::vector<double> xyz;
  Index next = 0;
  for (std::size_t v = 0; v < dense.size(); ++v) {
    if (dense[v] == kInvalidIndex) continue;
    dense[v] = next++;
    const Vec3 p = grid.corner({v % nodes_per[0], (v / nodes_per[0]) % nodes_per[1], v / (nodes_per[0] * nodes_per[1])});
    xyz.insert(xyz.end(), p.data(), p.data() + 3);
  }
  cage.rest_positions = Eigen::Map<const Matrix3Xd>(xyz.data(), 3, static_cast<Eigen::Index>(next));
  // Kuhn split: the 6 monotone paths from corner (0,0,0) to (1,1,1) of each cube.
  static constexpr std::size_t kPaths[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  std::vector<Index> corners;
  for (std::size_t c = 0; c < flags.size(); ++c) {
    if (flags[c] == kDropped) continue;
    for (const auto& path : kPaths) {
      std::array<std::size_t, 3> at = grid.coords(c);
      corners.push_back(dense[node_id(at)]);
      for (const std::size_t axis : path) {
        ++at[axis];
        corners.push_back(dense[node_id(at)]);
      }
    }
  }
  cage.tets = Eigen::Map<const Matrix4Xu>(corners.data(), 4, static_cast<Eigen::Index>(corners.size() / 4));
  for (Eigen::Index t = 0; t < cage.tets.cols(); ++t) {
    if (signed_volume(cage, static_cast<TetIndex>(t)) < 0.0) std::swap(cage.tets(2, t), cage.tets(3, t));
  }
  return cage;
}

}  // namespace

std::size_t count_lattice_cubes(const SurfaceMesh& mesh, const WindingNumberTree& winding, const LatticeGrid& spec) {
  Vec3 lo, hi;
  surface_box(mesh, lo, hi);
  Grid grid;
  if (!make_grid(lo, hi, spec, grid)) return 0;
  const auto flags = trim(mesh, winding, grid);
  return static_cast<std::size_t>(std::count_if(flags.begin(), flags.end(), [](std::uint8_t f) { return f != kDropped; }));
}

LatticeCage build_lattice_cage(const SurfaceMesh& mesh, const WindingNumberTree& winding, const LatticeGrid& spec) {
  Vec3 lo, hi;
  surface_box(mesh, lo, hi);
  Grid grid;
  LatticeCage result;
  result.grid = spec;
  if (!make_grid(lo, hi, spec, grid)) return result;
  const auto flags = trim(mesh, winding, grid);
  for (const std::uint8_t f : flags) {
    result.cubes += f != kDropped;
    result.surface_cubes += f == kSurface;
    result.bridge_cubes += f == kBridge;
  }
  result.mesh = lattice_tets(grid, flags);
  return result;
}

namespace {

/// One tried grid and the tets its cage would have (0: the grid was too fine).
struct Trial {
  LatticeGrid grid;
  std::size_t tets = 0;
};

/// How far a count is from the one asked, on a log scale (0: exact).
double miss(std::size_t tets, std::size_t asked) {
  if (tets == 0) return std::numeric_limits<double>::infinity();
  return std::abs(std::log(static_cast<double>(tets) / static_cast<double>(asked)));
}

}  // namespace

LatticeGrid search_lattice_grid(const SurfaceMesh& mesh, const WindingNumberTree& winding, std::size_t tets,
                                double tolerance, std::size_t* tries) {
  Vec3 lo, hi;
  surface_box(mesh, lo, hi);
  const Vec3 extent = (hi - lo).cwiseMax(1e-6 * (hi - lo).maxCoeff());
  std::vector<Trial> trials;
  const Vec3 centred = Vec3::Constant(0.5);
  auto attempt = [&](double cell, const Vec3& phase, const Vec3& stretch = Vec3::Ones()) -> const Trial& {
    const LatticeGrid grid{cell, phase, stretch};
    trials.push_back({grid, 6 * count_lattice_cubes(mesh, winding, grid)});
    return trials.back();
  };
  const auto best = [&]() {
    return *std::min_element(trials.begin(), trials.end(),
                             [&](const Trial& a, const Trial& b) { return miss(a.tets, tets) < miss(b.tets, tets); });
  };
  // Aim closer than asked where it is cheap: a few more tries buy a count near N.
  const double aim = std::log1p(std::min(tolerance, 0.05));
  // Secant steps on log(count) against log(cell): the count falls like cell^-3 inside
  // the solid and cell^-2 along the surface; the slope is measured, within [1, 4].
  double cell = std::cbrt(extent.prod() * 6.0 / static_cast<double>(tets));
  double slope = 3.0;
  const Trial* last = &attempt(cell, centred);
  for (int step = 0; step < 8 && miss(last->tets, tets) > aim; ++step) {
    const double ratio = last->tets == 0 ? 8.0 : static_cast<double>(last->tets) / static_cast<double>(tets);
    const double next = cell * std::pow(ratio, 1.0 / slope);
    const Trial before = *last;
    last = &attempt(next, centred);
    if (before.tets > 0 && last->tets > 0 && last->tets != before.tets) {
      slope = std::clamp(-std::log(static_cast<double>(last->tets) / static_cast<double>(before.tets)) / std::log(next / cell), 1.0, 4.0);
    }
    cell = next;
  }
  // Bisection between the finest cell that gave too few tets and the coarsest that
  // gave too many, where the secant steps brought a bracket but no count near enough.
  for (int step = 0; step < 10 && miss(best().tets, tets) > aim; ++step) {
    double fine = 0, coarse = std::numeric_limits<double>::infinity();
    for (const Trial& t : trials) {
      if (t.grid.phase != centred) continue;
      if (t.tets > tets || t.tets == 0) fine = std::max(fine, t.grid.cell);
      else coarse = std::min(coarse, t.grid.cell);
    }
    if (fine == 0 || !std::isfinite(coarse) || coarse / fine < 1.0 + 1e-9) break;
    attempt(std::sqrt(fine * coarse), centred);
  }
  // Small counts move in steps of whole cubes: other placements of the grid, axis by
  // axis, and cells a little finer or coarser may land nearer.
  const auto within = [&](const Trial& t) {
    return std::abs(static_cast<double>(t.tets) / static_cast<double>(tets) - 1.0) <= tolerance;
  };
  const double cell_best = best().grid.cell;
  constexpr double kPhases[3] = {0.5, 0.25, 0.75};
  for (int combo = 1; combo < 27 && !within(best()); ++combo) {
    const Vec3 phase(kPhases[combo % 3], kPhases[(combo / 3) % 3], kPhases[combo / 9]);
    for (const double scale : {1.0, 0.95, 1.05, 0.9, 1.1}) {
      if (within(attempt(cell_best * scale, phase))) break;
    }
  }
  for (int combo = 1; combo < 27 && !within(best()); ++combo) {
    const Vec3 stretch(kLatticeStretches[combo % 3], kLatticeStretches[(combo / 3) % 3], kLatticeStretches[combo / 9]);
    if (stretch.minCoeff() == stretch.maxCoeff()) continue;  // a scaled cube: tried above
    for (const double scale : {1.0, 0.95, 1.05}) {
      if (within(attempt(cell_best * scale, centred, stretch))) break;
    }
  }
  if (tries) *tries = trials.size();
  return best().grid;
}

}  // namespace fissure::bake
