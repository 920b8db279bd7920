#include "bake/collision_proxies.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <unordered_set>

#include "common/barycentric.h"
#include "bake/progress.h"
#include "bake/surface_distance.h"
#include "bake/surface_spheres.h"
#include "common/error.h"

namespace fissure::bake {
namespace {

using formats::TetClass;

/// A grid point: its integer coordinates.
struct GridKey {
  std::int32_t i, j, k;
  bool operator==(const GridKey&) const = default;
  auto operator<=>(const GridKey&) const = default;
};

struct GridKeyHash {
  std::size_t operator()(const GridKey& g) const {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (const std::int32_t v : {g.i, g.j, g.k}) h = (h ^ static_cast<std::uint32_t>(v)) * 0x100000001b3ull;
    return static_cast<std::size_t>(h);
  }
};

/// Grid points sit at origin + h (index + offset). The offset is half a cell plus a
/// little of no particular ratio, so that points practically never fall exactly on a
/// tet face: structured cages (and the Kuhn grids in the tests) put faces on planes
/// like x = y, where a half-cell lattice would sit exactly, and a point on a face would
/// belong to two tets.
const Vec3 kGridOffset(0.5137, 0.5271, 0.5419);

struct Sample {
  GridKey key;
  TetIndex tet;
};

Eigen::Matrix<double, 3, 4> tet_nodes(const TetMesh& cage, TetIndex t) {
  Eigen::Matrix<double, 3, 4> nodes;
  for (int i = 0; i < 4; ++i) nodes.col(i) = cage.rest_positions.col(cage.tets(i, t));
  return nodes;
}

/// Adds the signed tetrahedron (p, a, b, c) to the running volume and first moment.
void accumulate(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, double& volume, Vec3& moment) {
  const double v = (a - p).dot((b - p).cross(c - p)) / 6.0;
  volume += v;
  moment += v * (p + a + b + c) / 4.0;
}

}  // namespace

void validate(const SphereOptions& o) {
  if (!std::isfinite(o.radius) || o.radius < 0.0) {
    throw Error("--sphere-radius " + std::to_string(o.radius) + " is not a positive length",
                "give a radius in the mesh's units, e.g. 0.005, or leave it out for the default");
  }
  // Below a quarter of a radius the samples would cost more than the surface needs; past
  // 16 radii they would no longer cover it.
  if (o.surface_spacing != 0.0 && !(o.surface_spacing >= 0.25 && o.surface_spacing <= 16.0)) {
    throw Error("--surface-spacing " + std::to_string(o.surface_spacing) + " is out of range",
                "give 0 (no surface spheres) or 0.25 … 16 sphere radii; 2 is the default");
  }
}

double default_sphere_radius(const SurfaceMesh& mesh) {
  // The enclosed volume by the divergence theorem, from the triangles' signed volumes
  // about the centre (so rounding does not grow with the distance to the origin).
  const Vec3 centre = mesh.positions.rowwise().mean();
  double volume = 0.0;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3 a = mesh.positions.col(mesh.triangles(0, t)) - centre, b = mesh.positions.col(mesh.triangles(1, t)) - centre,
               c = mesh.positions.col(mesh.triangles(2, t)) - centre;
    volume += a.dot(b.cross(c)) / 6.0;
  }
  const double diagonal = (mesh.positions.rowwise().maxCoeff() - mesh.positions.rowwise().minCoeff()).norm();
  return kRadiusPerSize * std::max(std::cbrt(std::abs(volume)), diagonal / 20.0);
}

SolidPart solid_part(const formats::Bundle& b, const FaceRegions& regions, TetIndex tet,
                     const std::vector<std::size_t>& instances) {
  const auto nodes = tet_nodes(b.cage, tet);
  const Vec3 p = nodes.rowwise().mean();
  double volume = 0.0;
  Vec3 moment = Vec3::Zero();
  // The surface inside the tet, oriented outward from the solid like the render mesh.
  for (const std::size_t i : instances) {
    const std::vector<Vec4> polygon = clip_to_tet(b.embedding.instance_barycentric[i]);
    for (std::size_t k = 1; k + 1 < polygon.size(); ++k) {
      accumulate(p, nodes * polygon[0], nodes * polygon[k], nodes * polygon[k + 1], volume, moment);
    }
  }
  // The inside regions of the tet's faces, as fans from the face's first node; their
  // loops run counter-clockwise about the face normal, which points out of faces.tets(0).
  for (int local = 0; local < 4; ++local) {
    const FaceIndex f = b.faces.tet_faces(local, tet);
    const bool outward = b.faces.tets(0, f) == tet;
    const Vec3 o = b.cage.rest_positions.col(b.faces.nodes(0, f));
    for (std::uint64_t k = regions.offsets[f]; k < regions.offsets[f + 1]; ++k) {
      const Vec3 a = regions.pieces[k].col(0), c = regions.pieces[k].col(1);
      if (outward) {
        accumulate(p, o, a, c, volume, moment);
      } else {
        accumulate(p, o, c, a, volume, moment);
      }
    }
  }
  SolidPart part;
  part.volume = volume;
  part.centroid = volume > 0.0 ? Vec3(moment / volume) : p;
  return part;
}

namespace {

/// Everything the per-tet work shares.
struct CollisionGrid {
  const formats::Bundle& b;
  const FaceRegions& regions;
  const WindingNumberTree& winding;
  const SphereOptions& options;
  Vec3 origin;
  double spacing0;
};

/// Per-tet results of step 1, written by one thread each.
struct TetSamples {
  std::vector<std::vector<GridKey>> keys;
  std::vector<std::uint8_t> sampled;
  explicit TetSamples(std::size_t tets) : keys(tets), sampled(tets, 0) {}
};

std::string short_number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", value);
  return text;
}

/// Refuses a radius whose grid would take too long or too much memory, before any
/// work: the grid points step 1 scans, estimated from every tet's bounding box at the
/// starting spacing (an upper bound: outside tets are skipped). A radius of 1e-3 on a
/// 12-triangle cube used to run past 20 s with nothing shown (issue 46).
void check_grid_work(const TetMesh& cage, const SphereOptions& options, double radius, double spacing0) {
  const Vec3 origin = cage.rest_positions.rowwise().minCoeff();
  // Grid indices are 32-bit, and a lattice this fine would take forever to scan.
  const double extent = (cage.rest_positions.rowwise().maxCoeff() - origin).maxCoeff();
  const double cells = extent / spacing0;
  // A sphere wider than the whole cage holds nothing up; near the largest double its
  // grid's spacing overflows to infinity (--sphere-radius 1e308 crashed in the surface
  // distance query, fuzz-cli).
  if (!std::isfinite(spacing0) || (options.radius > 0.0 && radius > extent)) {
    throw Error("--sphere-radius " + short_number(radius) + " is larger than the cage, " + short_number(extent) +
                    " across",
                "use a radius of a few hundredths of the mesh's size, or leave it out for the default");
  }
  if (!(cells <= 1 << 20)) {
    throw Error("--sphere-radius " + short_number(radius) + " is too small for a cage " + short_number(extent) +
                    " across (" + short_number(cells) + " grid cells per axis)",
                "use a radius of at least a few thousandths of the cage size");
  }
  if (options.max_grid_points == 0) return;
  const double points = estimated_grid_points(cage, spacing0);
  if (points <= static_cast<double>(options.max_grid_points)) return;
  throw Error("--sphere-radius " + short_number(radius) + " implies scanning about " + short_number(points) +
                  " grid points for the collision spheres, past the limit of " +
                  short_number(static_cast<double>(options.max_grid_points)) + " (past it: minutes of work and gigabytes)",
              "use a larger radius (the default is 4.5 % of the cube root of the mesh's volume), or pass --no-work-limit to run "
              "it anyway");
}

/// Mass fraction and centre of mass of tet `t` (step 1a); `sampled` when it had to be
/// estimated on a lattice.
void tet_mass(const CollisionGrid& g, const std::vector<std::size_t>& instances, std::size_t t, formats::Collision& c,
              std::uint8_t& sampled) {
  const auto tet = static_cast<TetIndex>(t);
  const auto nodes = tet_nodes(g.b.cage, tet);
  const TetBarycentricFrame frame(nodes.col(0), nodes.col(1), nodes.col(2), nodes.col(3));
  const double tet_volume = signed_volume(nodes.col(0), nodes.col(1), nodes.col(2), nodes.col(3));
  bool beside_degenerate = false;
  for (int local = 0; local < 4; ++local) {
    beside_degenerate |= g.b.embedding.face_degenerate[g.b.faces.tet_faces(local, tet)] != 0;
  }
  if (g.b.embedding.tet_class[t] == TetClass::Inside) {
    c.mass_fraction[t] = 1.0;
  } else if (beside_degenerate) {
    // A face of this tet lies in the surface, where the exact integral needs the
    // face's inside region, which is not defined: estimate on a barycentric lattice.
    constexpr int kLattice = 16;
    int inside = 0, total = 0;
    Vec3 sum = Vec3::Zero();
    for (int i = 0; i <= kLattice; ++i) {
      for (int j = 0; i + j <= kLattice; ++j) {
        for (int k = 0; i + j + k <= kLattice; ++k) {
          // Lattice points nudged toward the centroid, off the faces themselves.
          const Vec4 beta = (Vec4(kLattice - i - j - k, i, j, k) / kLattice) * (1.0 - 1e-6) + Vec4::Constant(0.25e-6);
          const Vec3 x = nodes * beta;
          ++total;
          if (g.winding.winding_number(x) >= 0.5) {
            ++inside;
            sum += x;
          }
        }
      }
    }
    c.mass_fraction[t] = static_cast<double>(inside) / total;
    if (inside > 0) c.center_of_mass[t] = frame.coordinates(sum / inside);
    sampled = 1;
  } else {
    const SolidPart part = solid_part(g.b, g.regions, tet, instances);
    if (part.volume > 1e-10 * tet_volume) {
      c.mass_fraction[t] = std::clamp(part.volume / tet_volume, 0.0, 1.0);
      // The centroid of a solid part is inside the tet; clamp rounding noise (which
      // dominates when the part is a tiny corner) back into it.
      Vec4 beta = frame.coordinates(part.centroid).cwiseMax(0.0);
      c.center_of_mass[t] = beta / beta.sum();
    }  // else: a sliver at rounding level holds no mass; the centre stays the tet's centroid
  }
}

/// Step 1b: the grid points inside tet `t` and inside the solid.
std::vector<GridKey> scan_tet(const CollisionGrid& g, std::size_t t) {
  const auto nodes = tet_nodes(g.b.cage, static_cast<TetIndex>(t));
  const TetBarycentricFrame frame(nodes.col(0), nodes.col(1), nodes.col(2), nodes.col(3));
  const Vec3 lo = nodes.rowwise().minCoeff(), hi = nodes.rowwise().maxCoeff();
  const bool crossing = g.b.embedding.tet_class[t] == TetClass::Crossing;
  std::vector<GridKey> keys;
  const double h = g.spacing0;
  const Eigen::Vector3i first = ((lo - g.origin) / h - kGridOffset).array().ceil().cast<int>();
  const Eigen::Vector3i last = ((hi - g.origin) / h - kGridOffset).array().floor().cast<int>();
  for (int k = first.z(); k <= last.z(); ++k) {
    for (int j = first.y(); j <= last.y(); ++j) {
      for (int i = first.x(); i <= last.x(); ++i) {
        const Vec3 x = g.origin + h * (Vec3(i, j, k) + kGridOffset);
        if (frame.coordinates(x).minCoeff() < 0.0) continue;
        if (crossing && g.winding.winding_number(x) < 0.5) continue;
        keys.push_back({i, j, k});
      }
    }
  }
  return keys;
}

/// Step 2: every tet's samples, one per grid point: a point on a face shared by two
/// tets belongs to the lower-numbered one.
std::vector<Sample> unique_samples(const TetSamples& per_tet, formats::Collision& c, CollisionStats& st) {
  std::vector<Sample> samples;
  for (TetIndex t = 0; t < per_tet.keys.size(); ++t) {
    for (const GridKey& key : per_tet.keys[t]) samples.push_back({key, t});
    c.sampled_tets += per_tet.sampled[t];
  }
  std::sort(samples.begin(), samples.end(), [](const Sample& x, const Sample& y) {
    return x.key != y.key ? x.key < y.key : x.tet < y.tet;
  });
  samples.erase(std::unique(samples.begin(), samples.end(), [](const Sample& x, const Sample& y) { return x.key == y.key; }),
                samples.end());
  st.samples_kept = samples.size();
  return samples;
}

/// Step 3: drops spheres whose 26 neighbours are all present.
std::vector<Sample> cull_surrounded(const std::vector<Sample>& samples, bool cull) {
  std::unordered_set<GridKey, GridKeyHash> present;
  present.reserve(samples.size() * 2);
  for (const Sample& s : samples) present.insert(s.key);
  std::vector<Sample> kept;
  for (const Sample& s : samples) {
    bool surrounded = true;
    for (int dk = -1; dk <= 1 && surrounded; ++dk) {
      for (int dj = -1; dj <= 1 && surrounded; ++dj) {
        for (int di = -1; di <= 1 && surrounded; ++di) {
          if (di == 0 && dj == 0 && dk == 0) continue;
          surrounded = present.count({s.key.i + di, s.key.j + dj, s.key.k + dk}) > 0;
        }
      }
    }
    if (!surrounded || !cull) kept.push_back(s);
  }
  std::sort(kept.begin(), kept.end(), [](const Sample& x, const Sample& y) {
    return x.tet != y.tet ? x.tet < y.tet : x.key < y.key;
  });
  return kept;
}

/// v permuted: v[order[0]], v[order[1]], …
template <typename T>
void permute(std::vector<T>& v, const std::vector<std::size_t>& order) {
  std::vector<T> sorted;
  sorted.reserve(v.size());
  for (const std::size_t k : order) sorted.push_back(v[k]);
  v = std::move(sorted);
}

/// The order that sorts `tet`, keeping the order within a tet.
std::vector<std::size_t> order_by_tet(const std::vector<TetIndex>& tet) {
  std::vector<std::size_t> order(tet.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return tet[x] < tet[y]; });
  return order;
}

/// The bundle lists spheres by tet (docs/bundle-schema.md), grid spheres before surface
/// ones within a tet; the reserve too, in vertex order within a tet.
void sort_by_tet(formats::Collision& c) {
  const std::vector<std::size_t> spheres = order_by_tet(c.sphere_tet);
  permute(c.sphere_tet, spheres);
  permute(c.sphere_barycentric, spheres);
  permute(c.sphere_radius, spheres);
  const std::vector<std::size_t> reserve = order_by_tet(c.reserve_tet);
  permute(c.reserve_tet, reserve);
  permute(c.reserve_barycentric, reserve);
  permute(c.reserve_radius, reserve);
  permute(c.reserve_cover_tet, reserve);
}

}  // namespace

double estimated_grid_points(const TetMesh& cage, double spacing) {
  double points = 0.0;
  for (Index t = 0; t < cage.tet_count(); ++t) {
    const auto nodes = tet_nodes(cage, static_cast<TetIndex>(t));
    const Vec3 size = nodes.rowwise().maxCoeff() - nodes.rowwise().minCoeff();
    // Whole cells per axis, plus one: a thin tet still scans a row of points.
    points += (size.x() / spacing + 1.0) * (size.y() / spacing + 1.0) * (size.z() / spacing + 1.0);
  }
  return points;
}

void check_collision_work(const SurfaceMesh& mesh, const TetMesh& cage, const SphereOptions& options) {
  const double radius = options.radius > 0.0 ? options.radius : default_sphere_radius(mesh);
  check_grid_work(cage, options, radius, 2.0 * radius);
}

formats::Collision bake_collision(const formats::Bundle& b, const FaceRegions& regions, const WindingNumberTree& winding,
                                  const SphereOptions& options, CollisionStats* stats) {
  validate(options);
  CollisionStats local_stats;
  CollisionStats& st = stats ? *stats : local_stats;
  const TetMesh& cage = b.cage;
  formats::Collision c;
  c.target_radius = options.radius > 0.0 ? options.radius : default_sphere_radius(b.render);
  const CollisionGrid grid{b, regions, winding, options, cage.rest_positions.rowwise().minCoeff(), 2.0 * c.target_radius};
  check_grid_work(cage, options, c.target_radius, grid.spacing0);

  // Instances grouped by tet, for the mass integrals.
  std::vector<std::vector<std::size_t>> by_tet(cage.tet_count());
  for (std::size_t i = 0; i < b.embedding.instance_count(); ++i) by_tet[b.embedding.instance_tet[i]].push_back(i);

  // 1. Mass, then the grid points of every tet with solid in it.
  TetSamples per_tet(cage.tet_count());
  c.mass_fraction.assign(cage.tet_count(), 0.0);
  c.center_of_mass.assign(cage.tet_count(), Vec4::Constant(0.25));
  StageProgress progress("collision", "tets", cage.tet_count());
  tbb::parallel_for(std::size_t{0}, cage.tet_count(), [&](std::size_t t) {
    if (b.embedding.tet_class[t] != TetClass::Outside) {
      tet_mass(grid, by_tet[t], t, c, per_tet.sampled[t]);
      if (!(c.mass_fraction[t] <= 0.0)) per_tet.keys[t] = scan_tet(grid, t);
    }
    progress.advance();
  });

  const std::vector<Sample> samples = unique_samples(per_tet, c, st);
  const std::vector<Sample> kept = cull_surrounded(samples, options.cull_surrounded);
  st.culled = samples.size() - kept.size();
  // A grid sphere nearer the surface than r would poke out of it, holding the body off
  // what it touches (up to r) and standing on a few spheres instead of its surface: it
  // shrinks to its centre's distance from the surface, and goes where that is under
  // kLeastGridShare r (the surface spheres cover that layer).
  const SurfaceDistance distance(b.render);
  std::vector<double> radius(kept.size());
  tbb::parallel_for(std::size_t{0}, kept.size(), [&](std::size_t k) {
    const Sample& s = kept[k];
    radius[k] = std::min(c.target_radius,
                         distance.distance(grid.origin + grid.spacing0 * (Vec3(s.key.i, s.key.j, s.key.k) + kGridOffset)));
  });
  std::vector<std::uint8_t> has_sphere(cage.tet_count(), 0);
  for (std::size_t k = 0; k < kept.size(); ++k) {
    const Sample& s = kept[k];
    if (radius[k] < kLeastGridShare * c.target_radius) {
      ++st.near_surface;
      continue;
    }
    const Vec3 x = grid.origin + grid.spacing0 * (Vec3(s.key.i, s.key.j, s.key.k) + kGridOffset);
    const auto nodes = tet_nodes(cage, s.tet);
    const TetBarycentricFrame frame(nodes.col(0), nodes.col(1), nodes.col(2), nodes.col(3));
    c.sphere_tet.push_back(s.tet);
    c.sphere_barycentric.push_back(frame.coordinates(x));
    c.sphere_radius.push_back(radius[k]);
    has_sphere[s.tet] = 1;
  }
  if (options.surface_spacing > 0.0) {
    SurfaceSphereStats surface_stats;
    for (const SurfaceSphere& s :
         surface_spheres(b, winding, distance, c.target_radius, options.surface_spacing, &surface_stats)) {
      c.sphere_tet.push_back(s.tet);
      c.sphere_barycentric.push_back(s.barycentric);
      c.sphere_radius.push_back(s.radius);
      has_sphere[s.tet] = 1;
    }
    st.surface = surface_stats.spheres;
    st.surface_shrunk = surface_stats.shrunk;
    for (const ReserveSphere& s : reserve_spheres(b, c, winding, distance, c.target_radius, kReserveGapShare * c.target_radius)) {
      c.reserve_tet.push_back(s.sphere.tet);
      c.reserve_barycentric.push_back(s.sphere.barycentric);
      c.reserve_radius.push_back(s.sphere.radius);
      c.reserve_cover_tet.push_back(s.cover_tet);
    }
    st.reserve = c.reserve_tet.size();
  }
  for (std::size_t t = 0; t < cage.tet_count(); ++t) st.tets_bare += c.mass_fraction[t] > 0.0 && !has_sphere[t];
  sort_by_tet(c);
  return c;
}

}  // namespace fissure::bake
