#include "bake/surface_spheres.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <tuple>

#include "common/barycentric.h"

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

/// The sphere for surface point `sample`, or radius 0 when none fits.
SurfaceSphere fit_sphere(const formats::Bundle& b, const WindingNumberTree& winding, const SurfaceDistance& distance,
                         const std::vector<std::vector<std::size_t>>& instances, const Candidate& sample, double radius) {
  const SurfaceMesh& mesh = b.render;
  const TriangleIndex t = sample.triangle;
  const Vec3 a = mesh.positions.col(mesh.triangles(0, t)), bb = mesh.positions.col(mesh.triangles(1, t)),
             c = mesh.positions.col(mesh.triangles(2, t));
  const Vec3 p = sample.weights[0] * a + sample.weights[1] * bb + sample.weights[2] * c;
  const Vec3 normal = (bb - a).cross(c - a).normalized();  // outward: triangles run counter-clockwise seen from outside
  // The tet that holds p: of the triangle's instances, the one p is deepest inside.
  SurfaceSphere sphere;
  double best = -std::numeric_limits<double>::infinity();
  for (const std::size_t i : instances[t]) {
    const Vec4 beta = b.embedding.instance_barycentric[i] * sample.weights;
    if (beta.minCoeff() > best) {
      best = beta.minCoeff();
      sphere.tet = b.embedding.instance_tet[i];
    }
  }
  if (instances[t].empty()) return sphere;
  for (int k = 0; k <= kSurfaceShrinks; ++k) {
    const double r = std::ldexp(radius, -k);
    const Vec3 centre = p - r * normal;
    if (winding.winding_number(centre) < 0.5) continue;
    // p is r from the centre; nothing else of the surface may be much nearer, or the
    // sphere would poke out there (a thin part, a fold). As large as fits: never out.
    const double clearance = distance.distance(centre);
    if (clearance < kSurfaceFit * r) continue;
    Eigen::Matrix<double, 3, 4> nodes;
    for (int corner = 0; corner < 4; ++corner) nodes.col(corner) = b.cage.rest_positions.col(b.cage.tets(corner, sphere.tet));
    sphere.barycentric = TetBarycentricFrame(nodes.col(0), nodes.col(1), nodes.col(2), nodes.col(3)).coordinates(centre);
    sphere.radius = std::min(clearance, r);
    return sphere;
  }
  return sphere;
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
                    [&](std::size_t s) { fitted[s] = fit_sphere(b, winding, distance, instances, samples[s], radius); });
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

}  // namespace fissure::bake
