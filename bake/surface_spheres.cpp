#include "bake/surface_spheres.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <tuple>

#include "common/barycentric.h"
#include "formats/vertex_instances.h"

namespace fissure::bake {
namespace {

/// A point of the render surface that may become a sphere's: the sample cell it falls
/// in, how far from that cell's centre, and where on which triangle.
struct Candidate {
  std::array<std::int64_t, 3> cell;
  double distance = 0;
  TriangleIndex triangle = 0;
  Vec3 weights = Vec3::Zero();  ///< barycentric on the triangle
};

bool before(const Candidate& x, const Candidate& y) {
  return std::tie(x.cell, x.distance, x.triangle) < std::tie(y.cell, y.distance, y.triangle) ||
         (std::tie(x.cell, x.distance, x.triangle) == std::tie(y.cell, y.distance, y.triangle) &&
          std::lexicographical_compare(x.weights.data(), x.weights.data() + 3, y.weights.data(), y.weights.data() + 3));
}

/// A triangle's candidates: a barycentric lattice with steps at most half a cell, so
/// every cell the triangle crosses by more than a sliver gets one, and its centroid.
std::vector<Candidate> triangle_candidates(const SurfaceMesh& mesh, TriangleIndex t, const Vec3& origin, double cell) {
  std::vector<Candidate> out;
  if (is_degenerate(mesh, t)) return out;  // no normal to pull a sphere along
  const Vec3 a = mesh.positions.col(mesh.triangles(0, t)), b = mesh.positions.col(mesh.triangles(1, t)),
             c = mesh.positions.col(mesh.triangles(2, t));
  const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
  const int n = std::max(1, static_cast<int>(std::ceil(longest / (0.5 * cell))));
  const auto add = [&](const Vec3& w) {
    const Vec3 x = w[0] * a + w[1] * b + w[2] * c;
    const Vec3 g = (x - origin) / cell;
    const Vec3 floor = g.array().floor();
    Candidate candidate{{static_cast<std::int64_t>(floor.x()), static_cast<std::int64_t>(floor.y()),
                         static_cast<std::int64_t>(floor.z())},
                        (g - floor - Vec3::Constant(0.5)).norm(), t, w};
    out.push_back(candidate);
  };
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; i + j <= n; ++j) add(Vec3(n - i - j, i, j) / n);
  }
  add(Vec3::Constant(1.0 / 3.0));
  return out;
}

/// Rest-space point x in barycentric coordinates of the cage's tet t.
Vec4 rest_barycentric(const formats::Bundle& b, TetIndex t, const Vec3& x) {
  Eigen::Matrix<double, 3, 4> nodes;
  for (int corner = 0; corner < 4; ++corner) nodes.col(corner) = b.cage.rest_positions.col(b.cage.tets(corner, t));
  return TetBarycentricFrame(nodes.col(0), nodes.col(1), nodes.col(2), nodes.col(3)).coordinates(x);
}

/// The tet that holds surface point `weights` of triangle t: of the triangle's
/// instances, the one it is deepest inside; -1 when the triangle has none.
std::int64_t holding_tet(const formats::Bundle& b, const std::vector<std::vector<std::size_t>>& instances,
                         TriangleIndex t, const Vec3& weights) {
  std::int64_t tet = -1;
  double best = -std::numeric_limits<double>::infinity();
  for (const std::size_t i : instances[t]) {
    const Vec4 beta = b.embedding.instance_barycentric[i] * weights;
    if (beta.minCoeff() > best) {
      best = beta.minCoeff();
      tet = b.embedding.instance_tet[i];
    }
  }
  return tet;
}

/// The sphere touching the surface at p (outward normal n) from inside, bound to `tet`,
/// or radius 0 when none fits.
SurfaceSphere fit_sphere(const formats::Bundle& b, const WindingNumberTree& winding, const SurfaceDistance& distance,
                         const Vec3& p, const Vec3& normal, TetIndex tet, double radius) {
  SurfaceSphere sphere;
  sphere.tet = tet;
  for (int k = 0; k <= kSurfaceShrinks; ++k) {
    const double r = std::ldexp(radius, -k);
    const Vec3 centre = p - r * normal;
    if (winding.winding_number(centre) < 0.5) continue;
    // p is r from the centre; nothing else of the surface may be much nearer, or the
    // sphere would poke out there (a thin part, a fold). As large as fits: never out.
    const double clearance = distance.distance(centre);
    if (clearance < kSurfaceFit * r) continue;
    sphere.barycentric = rest_barycentric(b, tet, centre);
    sphere.radius = std::min(clearance, r);
    return sphere;
  }
  return sphere;
}

/// The sphere for the cell sample `sample`, bound to the tet that holds its point.
SurfaceSphere fit_sample(const formats::Bundle& b, const WindingNumberTree& winding, const SurfaceDistance& distance,
                         const std::vector<std::vector<std::size_t>>& instances, const Candidate& sample, double radius) {
  const SurfaceMesh& mesh = b.render;
  const TriangleIndex t = sample.triangle;
  const std::int64_t tet = holding_tet(b, instances, t, sample.weights);
  if (tet < 0) return {};
  const Vec3 a = mesh.positions.col(mesh.triangles(0, t)), bb = mesh.positions.col(mesh.triangles(1, t)),
             c = mesh.positions.col(mesh.triangles(2, t));
  const Vec3 p = sample.weights[0] * a + sample.weights[1] * bb + sample.weights[2] * c;
  const Vec3 normal = (bb - a).cross(c - a).normalized();  // outward: triangles run counter-clockwise seen from outside
  return fit_sphere(b, winding, distance, p, normal, static_cast<TetIndex>(tet), radius);
}

/// The reserve sphere for render vertex p (outward normal n), bound to `tet`: centred
/// r inside along n, as large as the surface lets it be there, its surface within
/// `miss` of p; r is halved until that holds (a sharp corner or edge needs a smaller
/// sphere to come near its tip). Radius 0 when none does.
SurfaceSphere fit_reserve(const formats::Bundle& b, const WindingNumberTree& winding, const SurfaceDistance& distance,
                          const Vec3& p, const Vec3& normal, TetIndex tet, double radius, double miss) {
  SurfaceSphere sphere;
  sphere.tet = tet;
  for (int k = 0; k <= kReserveShrinks; ++k) {
    const double r = std::ldexp(radius, -k);
    const Vec3 centre = p - r * normal;
    if (winding.winding_number(centre) < 0.5) continue;
    const double clearance = std::min(r, distance.distance(centre));
    if (r - clearance > miss) continue;
    sphere.barycentric = rest_barycentric(b, tet, centre);
    sphere.radius = clearance;
    return sphere;
  }
  return sphere;
}

/// Sphere indices by the grid cell their centre is in: a point's own cell and its 26
/// neighbours hold every centre within a cell of it.
class SphereCells {
 public:
  explicit SphereCells(double cell) : m_cell(cell) {}
  void add(const Vec3& x, std::size_t index) { m_cells[key(x)].push_back(index); }
  template <typename F>
  void for_each_near(const Vec3& x, const F& f) const {
    const auto [i, j, k] = key(x);
    for (std::int64_t di = -1; di <= 1; ++di) {
      for (std::int64_t dj = -1; dj <= 1; ++dj) {
        for (std::int64_t dk = -1; dk <= 1; ++dk) {
          const auto it = m_cells.find({i + di, j + dj, k + dk});
          if (it == m_cells.end()) continue;
          for (const std::size_t index : it->second) f(index);
        }
      }
    }
  }

 private:
  using Key = std::array<std::int64_t, 3>;
  [[nodiscard]] Key key(const Vec3& x) const {
    const Vec3 g = (x / m_cell).array().floor();
    return {static_cast<std::int64_t>(g.x()), static_cast<std::int64_t>(g.y()), static_cast<std::int64_t>(g.z())};
  }
  double m_cell;
  std::map<Key, std::vector<std::size_t>> m_cells;
};

/// Per render vertex, its outward normal: the sum of its triangles' area vectors
/// (zero where they cancel).
std::vector<Vec3> vertex_normals(const SurfaceMesh& mesh) {
  std::vector<Vec3> normal(mesh.vertex_count(), Vec3::Zero());
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3 a = mesh.positions.col(mesh.triangles(0, t)), bb = mesh.positions.col(mesh.triangles(1, t)),
               c = mesh.positions.col(mesh.triangles(2, t));
    const Vec3 area = (bb - a).cross(c - a);
    for (int corner = 0; corner < 3; ++corner) normal[mesh.triangles(corner, t)] += area;
  }
  return normal;
}

}  // namespace

std::vector<SurfaceSphere> surface_spheres(const formats::Bundle& b, const WindingNumberTree& winding,
                                           const SurfaceDistance& distance, double radius, double spacing,
                                           SurfaceSphereStats* stats) {
  const SurfaceMesh& mesh = b.render;
  // At 1, half the grid spheres' spacing: the surface sags at most 0.3 r between samples.
  const double cell = spacing * radius;
  const Vec3 origin = mesh.positions.rowwise().minCoeff();
  std::vector<std::vector<Candidate>> per_triangle(mesh.triangle_count());
  tbb::parallel_for(std::size_t{0}, mesh.triangle_count(), [&](std::size_t t) {
    per_triangle[t] = triangle_candidates(mesh, static_cast<TriangleIndex>(t), origin, cell);
  });
  std::vector<Candidate> samples;
  for (auto& list : per_triangle) samples.insert(samples.end(), list.begin(), list.end());
  per_triangle = {};
  // One sample a cell: the candidate nearest its centre (ties broken by triangle and
  // position, so the result does not depend on the order candidates were made in).
  std::sort(samples.begin(), samples.end(), before);
  samples.erase(std::unique(samples.begin(), samples.end(),
                            [](const Candidate& x, const Candidate& y) { return x.cell == y.cell; }),
                samples.end());

  std::vector<std::vector<std::size_t>> instances(mesh.triangle_count());
  for (std::size_t i = 0; i < b.embedding.instance_count(); ++i) instances[b.embedding.instance_triangle[i]].push_back(i);
  std::vector<SurfaceSphere> fitted(samples.size());
  tbb::parallel_for(std::size_t{0}, samples.size(),
                    [&](std::size_t s) { fitted[s] = fit_sample(b, winding, distance, instances, samples[s], radius); });
  SurfaceSphereStats local;
  SurfaceSphereStats& st = stats ? *stats : local;
  std::vector<SurfaceSphere> spheres;
  for (const SurfaceSphere& s : fitted) {
    if (!(s.radius > 0.0)) {
      ++st.dropped;
      continue;
    }
    st.shrunk += s.radius < kSurfaceFit * radius * (1 - 1e-12);  // unhalved ones keep ≥ kSurfaceFit r
    spheres.push_back(s);
  }
  st.spheres = spheres.size();
  return spheres;
}

std::vector<ReserveSphere> reserve_spheres(const formats::Bundle& b, const formats::Collision& c,
                                           const WindingNumberTree& winding, const SurfaceDistance& distance,
                                           double radius, double gap) {
  const std::vector<formats::VertexInstance> held = formats::vertex_instances(b);
  const std::vector<Vec3> normal = vertex_normals(b.render);
  // Every sphere so far (the bundle's, then the reserve made before), by grid cell: a
  // sphere that passes within the gap of a point has its centre within 2r of it.
  struct Placed {
    Vec3 centre;
    double radius;
    TetIndex tet;
    bool reserve;
  };
  std::vector<Placed> placed;
  SphereCells cells(2.0 * radius);
  const auto place = [&](TetIndex t, const Vec4& beta, double r, bool reserve) {
    Vec3 x = Vec3::Zero();
    for (int corner = 0; corner < 4; ++corner) x += beta[corner] * b.cage.rest_positions.col(b.cage.tets(corner, t));
    cells.add(x, placed.size());
    placed.push_back({x, r, t, reserve});
  };
  for (std::size_t k = 0; k < c.sphere_tet.size(); ++k) place(c.sphere_tet[k], c.sphere_barycentric[k], c.sphere_radius[k], false);
  std::vector<ReserveSphere> reserve;
  for (std::size_t v = 0; v < held.size(); ++v) {
    if (held[v].instance == formats::kNoInstance || !(normal[v].squaredNorm() > 0.0)) continue;
    const TetIndex t = b.embedding.instance_tet[held[v].instance];
    const Vec3 p = b.render.positions.col(static_cast<Eigen::Index>(v));
    // From p to the surface of the nearest sphere of t, and of the nearest of the
    // bundle's (any tet), within the gap.
    double own = std::numeric_limits<double>::infinity(), nearest = gap;
    TetIndex cover = kInvalidIndex;
    cells.for_each_near(p, [&](std::size_t k) {
      const double d = (placed[k].centre - p).norm() - placed[k].radius;
      if (placed[k].tet == t) own = std::min(own, d);
      if (!placed[k].reserve && d <= nearest) {
        nearest = d;
        cover = placed[k].tet;
      }
    });
    if (own <= gap) continue;
    const SurfaceSphere s = fit_reserve(b, winding, distance, p, normal[v].normalized(), t, radius, 0.5 * gap);
    if (!(s.radius > 0.0)) continue;
    place(t, s.barycentric, s.radius, true);
    reserve.push_back({s, cover});
  }
  return reserve;
}

}  // namespace fissure::bake
