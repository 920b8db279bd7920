// The coverage invariant in exact rational arithmetic: for every render triangle, the
// areas of (triangle ∩ tet) over its instances add up to the triangle's area with no
// rounding at all. Areas are compared as projections onto the coordinate plane most
// parallel to the triangle (a linear function of exact coordinates, so exact), and each
// piece is clipped with exact constructions. This checks the bake's assignment against
// CGAL independently of the double-precision clipping that `verify` uses.
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <gtest/gtest.h>

#include "bake/bake.h"
#include "formats/cage_io.h"
#include "tests/support/procedural.h"

namespace fissure::bake {
namespace {

using K = CGAL::Exact_predicates_exact_constructions_kernel;
using FT = K::FT;
using P3 = K::Point_3;

P3 point(const Matrix3Xd& m, Index i) { return {m(0, i), m(1, i), m(2, i)}; }

/// Signed projected area (×2) of a polygon on the plane that drops `axis`.
FT projected_twice_area(const std::vector<P3>& polygon, int axis) {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  FT sum = 0;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const P3& a = polygon[i];
    const P3& b = polygon[(i + 1) % polygon.size()];
    sum += a[u] * b[v] - a[v] * b[u];
  }
  return sum;
}

/// Clips a convex polygon to the closed half-space on the NEGATIVE side of plane (a,b,c)
/// (the inside of a positively oriented tet for its outward-ordered faces).
std::vector<P3> clip(const std::vector<P3>& polygon, const P3& a, const P3& b, const P3& c) {
  const K::Vector_3 normal = CGAL::cross_product(b - a, c - a);
  std::vector<P3> out;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const P3& p = polygon[i];
    const P3& q = polygon[(i + 1) % polygon.size()];
    const FT sp = (p - a) * normal, sq = (q - a) * normal;
    if (sp <= 0) out.push_back(p);
    if ((sp < 0 && sq > 0) || (sp > 0 && sq < 0)) out.push_back(p + (q - p) * (sp / (sp - sq)));
  }
  return out;
}

void expect_exact_coverage(const SurfaceMesh& mesh, const TetMesh& cage, const std::string& what) {
  BakeOptions options;
  options.walls = options.collision = false;
  const formats::Bundle bundle = embed(mesh, cage, options, what, "cage");
  const auto& e = bundle.embedding;
  std::size_t i = 0, checked = 0;
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    const std::vector<P3> triangle{point(mesh.positions, mesh.triangles(0, t)), point(mesh.positions, mesh.triangles(1, t)),
                                   point(mesh.positions, mesh.triangles(2, t))};
    const K::Vector_3 normal = CGAL::cross_product(triangle[1] - triangle[0], triangle[2] - triangle[0]);
    int axis = 0;
    for (int k = 1; k < 3; ++k) {
      if (CGAL::abs(normal[k]) > CGAL::abs(normal[axis])) axis = k;
    }
    FT covered = 0;
    for (; i < e.instance_count() && e.instance_triangle[i] == t; ++i) {
      std::vector<P3> piece = triangle;
      P3 nodes[4];
      for (int k = 0; k < 4; ++k) nodes[k] = point(cage.rest_positions, cage.tets(k, e.instance_tet[i]));
      for (const auto& face : kTetFaceNodes) {
        if (!piece.empty()) piece = clip(piece, nodes[face[0]], nodes[face[1]], nodes[face[2]]);
      }
      if (piece.size() >= 3) covered += projected_twice_area(piece, axis);
    }
    EXPECT_TRUE(covered == projected_twice_area(triangle, axis))
        << what << ": triangle " << t << " covered " << CGAL::to_double(covered) << " of "
        << CGAL::to_double(projected_twice_area(triangle, axis));
    ++checked;
  }
  EXPECT_EQ(checked, mesh.triangle_count());
}

TEST(ExactCoverage, ProceduralMeshesInGridCages) {
  const Vec3 lo(-1.37, -1.41, -1.33), hi(1.39, 1.35, 1.43);
  expect_exact_coverage(testing::icosphere(2, 1.0), testing::grid_cage(lo, hi, 4, 5, 3), "sphere");
  expect_exact_coverage(testing::torus(0.9, 0.35, 32, 16), testing::grid_cage(lo, hi, 5, 5, 2), "torus");
  expect_exact_coverage(testing::box_surface(Vec3(-0.93, -0.71, -0.52), Vec3(0.88, 0.67, 0.91), 4),
                        testing::grid_cage(lo, hi, 3, 4, 5), "box");
  expect_exact_coverage(testing::box_surface(Vec3::Constant(-0.5), Vec3::Constant(0.5), 4),
                        testing::grid_cage(Vec3::Constant(-1), Vec3::Constant(1), 4, 4, 4), "aligned box");
}

TEST(ExactCoverage, BunnyInASharedCage) {
  const auto mesh = import_render_mesh(testing::data_dir() / "meshes" / "bunny-5k.obj").mesh;
  const auto cage = formats::read_cage(testing::data_dir() / "cages" / "bunny-5k-cage-100.node");
  expect_exact_coverage(mesh, cage.mesh, "bunny-5k in cage-100");
}

}  // namespace
}  // namespace fissure::bake
