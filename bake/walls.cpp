#include "bake/walls.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <queue>
#include <utility>
#include <vector>

#include "bake/progress.h"
#include "bake/surface_distance.h"
#include "common/error.h"

namespace fissure::bake {
namespace {

double point_segment_distance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double length2 = ab.squaredNorm();
  const double t = length2 > 0.0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

/// (u, v) moved onto the face triangle (u, v ≥ 0, u + v ≤ 1) and nudged inside, so
/// texels beyond the face continue the classification of its nearest point.
Vec2 onto_face(double u, double v) {
  u = std::clamp(u, 0.0, 1.0);
  v = std::clamp(v, 0.0, 1.0);
  if (u + v > 1.0) {
    const double excess = 0.5 * (u + v - 1.0);
    u = std::clamp(u - excess, 0.0, 1.0);
    v = std::clamp(v - excess, 0.0, 1.0);
  }
  constexpr double kInward = 1e-9;
  return {u + kInward * (1.0 / 3.0 - u), v + kInward * (1.0 / 3.0 - v)};
}

std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

double cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

/// Texels beyond the face's diagonal (u + v > 1) repeat their mirror image across it,
/// so the field continues smoothly for bilinear filtering at the face's far edge.
template <typename T>
void mirror_beyond_diagonal(T* tile, std::size_t res) {
  for (std::size_t j = 0; j < res; ++j) {
    for (std::size_t i = 0; i < res; ++i) {
      if (i + j + 1 > res) tile[j * res + i] = tile[(res - 1 - i) * res + (res - 1 - j)];
    }
  }
}

/// Inside (1) / outside (0) of every texel centre of a tile. Centres on the face
/// (u + v ≤ 1) are classified exactly: a scan line per row finds where the row crosses
/// the region's boundary (in double), and any centre within rounding of a crossing, or
/// any row passing within rounding of a boundary vertex, is decided by the exact winding
/// test instead. Centres beyond the face are left 0: the tile mirrors them afterwards.
std::vector<std::uint8_t> classify_texels(const FaceRegions& regions, FaceIndex f, const Vec3& n0, const Vec3& e1,
                                          const Vec3& e2, std::size_t res) {
  const Vec3 normal = e1.cross(e2);
  int axis = 0;
  normal.cwiseAbs().maxCoeff(&axis);
  const int U = (axis + 1) % 3, V = (axis + 2) % 3;
  auto flat = [&](const Vec3& p) { return Vec2(p[U], p[V]); };
  const Vec2 t = flat(e1);
  const double scale = e1.norm() + e2.norm();
  constexpr double kTolerance = 1e-9;
  std::vector<std::pair<Vec2, Vec2>> pieces;
  for (std::uint64_t k = regions.offsets[f]; k < regions.offsets[f + 1]; ++k) {
    pieces.emplace_back(flat(regions.pieces[k].col(0)), flat(regions.pieces[k].col(1)));
  }
  std::vector<std::uint8_t> classes(res * res, 0);
  struct Crossing {
    double u;         ///< where the row meets the piece
    int step;         ///< winding change when passing it
    double tolerance; ///< rounding bound of u: grows as the piece turns parallel to the row
    bool operator<(const Crossing& other) const { return u < other.u; }
  };
  std::vector<Crossing> crossings;
  // Centres on the face's far edge (u + v = 1 happens for every even resolution) are
  // nudged inside first; every other centre on the face is tested where it is.
  auto exact = [&](double u, double v) {
    const Vec2 on = u + v >= 1.0 ? onto_face(u, v) : Vec2(u, v);
    return region_winding(regions, f, normal, n0 + on.x() * e1 + on.y() * e2) != 0;
  };
  const double t_length = t.norm();
  for (std::size_t j = 0; j < res; ++j) {
    const double v = (static_cast<double>(j) + 0.5) / static_cast<double>(res);
    const Vec2 r0 = flat(n0 + v * e2);
    // Signed distances of the boundary vertices from the row line.
    bool degenerate = false;
    crossings.clear();
    for (const auto& [a, b] : pieces) {
      const double side_a = cross2(t, a - r0) / t_length, side_b = cross2(t, b - r0) / t_length;
      if (std::abs(side_a) <= kTolerance * scale || std::abs(side_b) <= kTolerance * scale) {
        degenerate = true;
        break;
      }
      if ((side_a < 0) == (side_b < 0)) continue;
      const Vec2 d = b - a;
      // Moving along +t past a boundary piece with direction d changes the winding by
      // −sign(t × d): the ray from a point towards +t counts the pieces ahead of it.
      const double sine = std::abs(cross2(t, d)) / (t_length * d.norm());
      crossings.push_back({cross2(a - r0, d) / cross2(t, d), cross2(t, d) > 0 ? 1 : -1, kTolerance / std::max(sine, 1e-300)});
    }
    int ahead = 0;
    for (const auto& c : crossings) ahead += c.step;
    std::sort(crossings.begin(), crossings.end());
    std::size_t next = 0;
    for (std::size_t i = 0; i < res; ++i) {
      const double u = (static_cast<double>(i) + 0.5) / static_cast<double>(res);
      if ((static_cast<double>(i) + 0.5) + (static_cast<double>(j) + 0.5) > static_cast<double>(res)) break;
      while (next < crossings.size() && crossings[next].u < u) ahead -= crossings[next++].step;
      const bool near_crossing = (next < crossings.size() && crossings[next].u - u <= crossings[next].tolerance) ||
                                 (next > 0 && u - crossings[next - 1].u <= crossings[next - 1].tolerance);
      classes[j * res + i] = (degenerate || near_crossing) ? exact(u, v) : ahead != 0;
    }
  }
  return classes;
}

}  // namespace

void validate(const WallOptions& o) {
  if (o.resolution < 2 || o.resolution > 4096) {
    throw Error("--wall-res " + std::to_string(o.resolution) + " is out of range", "use 2 … 4096 texels (8 … 256 is typical)");
  }
  if (!(o.sdf_range_texels > 0.0)) throw Error("the wall SDF range must be positive");
  if (o.depth_divisor == 0) throw Error("the wall depth divisor must be positive");
  if (o.detail_resolution < 4 || o.detail_resolution > 8192) throw Error("the wall detail resolution must be 4 … 8192");
}

void bake_detail(std::uint32_t resolution, std::uint64_t seed, std::vector<std::uint8_t>& height,
                 std::vector<std::uint8_t>& normal) {
  // Periodic gradient (Perlin-style) noise: lattice gradients repeat every `cells`
  // cells, so the map tiles seamlessly. Octaves double the cell count.
  const std::uint32_t n = resolution;
  std::vector<double> field(static_cast<std::size_t>(n) * n, 0.0);
  double amplitude = 1.0, total_amplitude = 0.0;
  std::uint64_t state = seed;
  for (std::uint32_t cells = 4; cells <= 32 && cells <= n; cells *= 2) {
    std::vector<Vec2> gradients(static_cast<std::size_t>(cells) * cells);
    for (Vec2& g : gradients) {
      const double angle = 2.0 * std::numbers::pi * static_cast<double>(splitmix64(state) >> 11) * 0x1.0p-53;
      g = Vec2(std::cos(angle), std::sin(angle));
    }
    auto gradient = [&](std::uint32_t i, std::uint32_t j) -> const Vec2& { return gradients[(j % cells) * cells + (i % cells)]; };
    for (std::uint32_t y = 0; y < n; ++y) {
      for (std::uint32_t x = 0; x < n; ++x) {
        const double fx = (x + 0.5) * cells / n, fy = (y + 0.5) * cells / n;
        const auto i = static_cast<std::uint32_t>(fx), j = static_cast<std::uint32_t>(fy);
        const double dx = fx - i, dy = fy - j;
        auto fade = [](double t) { return t * t * t * (t * (t * 6 - 15) + 10); };
        const double n00 = gradient(i, j).dot(Vec2(dx, dy)), n10 = gradient(i + 1, j).dot(Vec2(dx - 1, dy));
        const double n01 = gradient(i, j + 1).dot(Vec2(dx, dy - 1)), n11 = gradient(i + 1, j + 1).dot(Vec2(dx - 1, dy - 1));
        const double sx = fade(dx), sy = fade(dy);
        field[y * n + x] += amplitude * ((n00 * (1 - sx) + n10 * sx) * (1 - sy) + (n01 * (1 - sx) + n11 * sx) * sy);
      }
    }
    total_amplitude += amplitude;
    amplitude *= 0.5;
  }
  height.resize(field.size());
  normal.resize(field.size() * 3);
  for (std::size_t i = 0; i < field.size(); ++i) {
    const double h = std::clamp(0.5 + 0.5 * field[i] / (0.7 * total_amplitude), 0.0, 1.0);
    height[i] = static_cast<std::uint8_t>(std::lround(255.0 * h));
  }
  // Normals by central differences with wrap-around, one texel = 1/n of the tile,
  // heights in tile units scaled so slopes stay visible.
  constexpr double kBumpScale = 4.0;
  for (std::uint32_t y = 0; y < n; ++y) {
    for (std::uint32_t x = 0; x < n; ++x) {
      auto h = [&](std::uint32_t i, std::uint32_t j) { return height[(j % n) * n + (i % n)] / 255.0; };
      const double ddx = (h(x + 1, y) - h(x + n - 1, y)) * 0.5 * kBumpScale;
      const double ddy = (h(x, y + 1) - h(x, y + n - 1)) * 0.5 * kBumpScale;
      const Vec3 nrm = Vec3(-ddx, -ddy, 1.0).normalized();
      for (int k = 0; k < 3; ++k) {
        normal[3 * (y * n + x) + static_cast<std::uint32_t>(k)] =
            static_cast<std::uint8_t>(std::lround(std::clamp(127.5 + 127.5 * nrm[k], 0.0, 255.0)));
      }
    }
  }
}

double triangle_clearance(const SurfaceDistance& surface, const Vec3& a, const Vec3& b, const Vec3& c, double tolerance,
                          int max_splits) {
  struct Piece {
    std::array<Vec3, 3> corner;
    std::array<double, 3> distance;  ///< from each corner to the surface
    double bound = 0;                ///< no point of the piece is nearer the surface
  };
  // At a point x = Σ λᵢ vᵢ of a piece, d(x) ≥ Σ λᵢ (dᵢ − |x − vᵢ|) ≥ min dᵢ − Σ λᵢ |x − vᵢ|,
  // and Σ λᵢ |x − vᵢ| is at most the circumradius (its square is at most Σ λᵢ |x − vᵢ|²
  // = R² − |x − centre|²) and at most the diameter (for slivers, whose R is huge).
  const auto piece = [](const Vec3& p, const Vec3& q, const Vec3& r, double dp, double dq, double dr) {
    const double a = (q - p).norm(), b = (r - p).norm(), c = (r - q).norm();
    const double twice_area = (q - p).cross(r - p).norm();
    const double circumradius = twice_area > 0.0 ? a * b * c / (2.0 * twice_area) : std::numeric_limits<double>::infinity();
    return Piece{{p, q, r}, {dp, dq, dr}, std::min({dp, dq, dr}) - std::min(circumradius, std::max({a, b, c}))};
  };
  const auto higher_bound = [](const Piece& x, const Piece& y) { return x.bound > y.bound; };
  std::priority_queue<Piece, std::vector<Piece>, decltype(higher_bound)> pieces(higher_bound);
  pieces.push(piece(a, b, c, surface.distance(a), surface.distance(b), surface.distance(c)));
  for (int splits = 0;; ++splits) {
    const Piece p = pieces.top();  // the lowest bound: the triangle's least distance is at least this
    const double nearest = std::min({p.distance[0], p.distance[1], p.distance[2]});
    if (nearest <= 0.0) return 0.0;  // the face touches the surface: no bound above 0 exists
    if (nearest - p.bound <= tolerance * nearest || splits >= max_splits) return std::max(0.0, p.bound);
    pieces.pop();
    const auto& [x0, x1, x2] = p.corner;
    const auto& [d0, d1, d2] = p.distance;
    const Vec3 m01 = 0.5 * (x0 + x1), m12 = 0.5 * (x1 + x2), m20 = 0.5 * (x2 + x0);
    const double e01 = surface.distance(m01), e12 = surface.distance(m12), e20 = surface.distance(m20);
    pieces.push(piece(x0, m01, m20, d0, e01, e20));
    pieces.push(piece(m01, x1, m12, e01, d1, e12));
    pieces.push(piece(m20, m12, x2, e20, e12, d2));
    pieces.push(piece(m01, m12, m20, e01, e12, e20));
  }
}

namespace {

/// A face's frame on its tile: u runs along e1, v along e2 from corner n0.
struct TileFrame {
  Vec3 n0, e1, e2;
  [[nodiscard]] Vec3 at(double u, double v) const { return n0 + u * e1 + v * e2; }
};

TileFrame tile_frame(const formats::Bundle& b, FaceIndex f) {
  const auto& nodes = b.cage.rest_positions;
  const Vec3 n0 = nodes.col(b.faces.nodes(0, f));
  return {n0, nodes.col(b.faces.nodes(1, f)) - n0, nodes.col(b.faces.nodes(2, f)) - n0};
}

/// Face f's signed-distance tile (res² texels, 128 and up inside): the distance to its
/// exact contour, clamped at sdf_range_texels texels.
void rasterise_sdf(const formats::Bundle& b, const FaceRegions& regions, FaceIndex f, std::size_t res,
                   double sdf_range_texels, std::uint8_t* sdf) {
  const auto& e = b.embedding;
  const TileFrame frame = tile_frame(b, f);
  const double texel = std::max(frame.e1.norm(), frame.e2.norm()) / static_cast<double>(res);
  const double range = sdf_range_texels * texel;
  const std::vector<std::uint8_t> classes = classify_texels(regions, f, frame.n0, frame.e1, frame.e2, res);
  for (std::size_t j = 0; j < res; ++j) {
    for (std::size_t i = 0; i < res; ++i) {
      const double u = (static_cast<double>(i) + 0.5) / static_cast<double>(res);
      const double v = (static_cast<double>(j) + 0.5) / static_cast<double>(res);
      const Vec3 x = frame.at(u, v);
      double d = range;
      for (std::uint64_t s = e.contour_offsets[f]; s < e.contour_offsets[f + 1]; ++s) {
        d = std::min(d, point_segment_distance(x, e.contour_points[s].col(0), e.contour_points[s].col(1)));
      }
      const double t = d / range;  // 0 on the contour, 1 at the range and beyond
      sdf[j * res + i] = classes[j * res + i] ? static_cast<std::uint8_t>(128 + std::lround(127.0 * t))
                                              : static_cast<std::uint8_t>(127 - std::lround(127.0 * t));
    }
  }
  mirror_beyond_diagonal(sdf, res);
}

/// Face f's depth tile (dres² texels, metres below the outer surface, 0 outside the
/// solid); returns its deepest texel.
double rasterise_depth(const formats::Bundle& b, const FaceRegions& regions, FaceIndex f, const SurfaceDistance& surface,
                       std::size_t dres, float* depth_m) {
  const TileFrame frame = tile_frame(b, f);
  const Vec3 normal = frame.e1.cross(frame.e2);
  double deepest = 0.0;
  bool have_hint = false;
  Vec3 hint = Vec3::Zero();
  for (std::size_t j = 0; j < dres; ++j) {
    for (std::size_t i = 0; i < dres; ++i) {
      const double u = (static_cast<double>(i) + 0.5) / static_cast<double>(dres);
      const double v = (static_cast<double>(j) + 0.5) / static_cast<double>(dres);
      if (static_cast<double>(i + j + 1) > static_cast<double>(dres)) continue;
      const Vec2 on = onto_face(u, v);
      const Vec3 x = frame.at(on.x(), on.y());
      if (region_winding(regions, f, normal, x) == 0) continue;
      // Neighbouring texels have nearby closest points: seed each search with the last.
      const double depth = surface.distance(x, hint, have_hint);
      have_hint = true;
      depth_m[j * dres + i] = static_cast<float>(depth);
      deepest = std::max(deepest, depth);
    }
  }
  mirror_beyond_diagonal(depth_m, dres);
  return deepest;
}

/// The faces that get a tile (the crossing ones), in face order; sets w's face classes
/// and tile indices.
std::vector<FaceIndex> assign_tiles(const FaceRegions& regions, formats::Walls& w) {
  const std::size_t face_count = regions.face_class.size();
  w.face_class.resize(face_count);
  w.face_tile.assign(face_count, kInvalidIndex);
  std::vector<FaceIndex> tiled;
  for (FaceIndex f = 0; f < face_count; ++f) {
    w.face_class[f] = regions.face_class[f];
    if (regions.face_class[f] == FaceClass::Crossing) {  // degenerate faces get no tile
      w.face_tile[f] = static_cast<Index>(tiled.size());
      tiled.push_back(f);
    }
  }
  return tiled;
}

void check_tile_budget(std::size_t tiles, std::size_t res, std::size_t dres, const WallOptions& options) {
  const std::size_t bytes = tiles * (res * res + dres * dres);
  if (bytes > options.memory_budget_bytes) {
    throw Error("--wall-res " + std::to_string(res) + " needs " + std::to_string(bytes >> 20) + " MiB of tiles for " +
                    std::to_string(tiles) + " crossing faces, over the budget of " +
                    std::to_string(options.memory_budget_bytes >> 20) + " MiB",
                "lower --wall-res, or raise --wall-memory-budget (MiB)");
  }
}

/// Each texel of a tile measures its distance to every contour segment on its face: a
/// resolution set high (`--wall-res 4096`: 19 s for the 8 tiles of a 320-triangle
/// sphere) is refused past options.max_work, with the estimate and the flag to force it.
void check_wall_work(const formats::Bundle& b, const std::vector<FaceIndex>& tiled, const WallOptions& options) {
  if (options.max_work == 0 || options.resolution <= WallOptions{}.resolution) return;
  const double texels = static_cast<double>(options.resolution) * options.resolution;
  double work = 0.0;
  for (const FaceIndex f : tiled) {
    work += texels * static_cast<double>(1 + b.embedding.contour_offsets[f + 1] - b.embedding.contour_offsets[f]);
  }
  if (work <= static_cast<double>(options.max_work)) return;
  char text[200];
  std::snprintf(text, sizeof text, "--wall-res %u implies about %.3g texel distance tests for %zu tiles, past the limit of %.3g",
                options.resolution, work, tiled.size(), static_cast<double>(options.max_work));
  throw Error(text, "lower --wall-res (the default is 64), or pass --no-work-limit to run it anyway");
}

}  // namespace

formats::Walls bake_walls(const formats::Bundle& b, const FaceRegions& regions, const WallOptions& options) {
  validate(options);
  formats::Walls w;
  const std::size_t face_count = b.faces.face_count();
  w.resolution = options.resolution;
  w.sdf_range_texels = options.sdf_range_texels;
  w.depth_resolution = std::max<std::uint32_t>(4, options.resolution / options.depth_divisor);
  w.detail_resolution = options.detail_resolution;
  w.detail_seed = options.detail_seed;
  w.face_inside_area = regions.inside_area;
  const std::vector<FaceIndex> tiled = assign_tiles(regions, w);
  const std::size_t res = options.resolution, dres = w.depth_resolution;
  check_tile_budget(tiled.size(), res, dres, options);
  check_wall_work(b, tiled, options);
  w.sdf.assign(tiled.size() * res * res, 0);
  w.depth.assign(tiled.size() * dres * dres, 0);

  const SurfaceDistance surface(b.render);
  std::vector<double> max_depth(tiled.size(), 0.0);
  std::vector<float> depth_m(tiled.size() * dres * dres, 0.0f);
  StageProgress progress("walls", "tiles", tiled.size());  // --wall-res 4096: 19 s for the 8 tiles of a small sphere
  tbb::parallel_for(std::size_t{0}, tiled.size(), [&](std::size_t tile) {
    rasterise_sdf(b, regions, tiled[tile], res, options.sdf_range_texels, &w.sdf[tile * res * res]);
    max_depth[tile] = rasterise_depth(b, regions, tiled[tile], surface, dres, &depth_m[tile * dres * dres]);
    progress.advance();
  });
  double deepest = 0.0;
  for (const double d : max_depth) deepest = std::max(deepest, d);
  w.depth_scale = deepest > 0.0 ? deepest : 1.0;  // 255 stands for the deepest texel
  for (std::size_t i = 0; i < depth_m.size(); ++i) {
    w.depth[i] = static_cast<std::uint8_t>(std::lround(255.0 * std::clamp(depth_m[i] / w.depth_scale, 0.0, 1.0)));
  }
  const auto& nodes = b.cage.rest_positions;
  w.face_clearance.assign(face_count, 0.0);
  tbb::parallel_for(FaceIndex{0}, static_cast<FaceIndex>(face_count), [&](FaceIndex f) {
    if (w.face_class[f] != FaceClass::Inside) return;
    w.face_clearance[f] = triangle_clearance(surface, nodes.col(b.faces.nodes(0, f)), nodes.col(b.faces.nodes(1, f)),
                                             nodes.col(b.faces.nodes(2, f)));
  });
  bake_detail(options.detail_resolution, options.detail_seed, w.detail_height, w.detail_normal);
  return w;
}

}  // namespace fissure::bake
