// Orientation repair and self-intersection counting, which the bake runs before the
// embedding (issue 17: one flipped triangle, an inside-out mesh or a self-intersecting
// one used to fail the bake's own collision-mass check, exit 2).
#include <gtest/gtest.h>

#include "bake/mesh_import.h"
#include "bake/self_intersections.h"
#include "bake/surface_orientation.h"
#include "tests/support/procedural.h"

namespace fissure::bake {
namespace {

void flip(SurfaceMesh& mesh, Index t) { std::swap(mesh.triangles(1, t), mesh.triangles(2, t)); }

void flip_all(SurfaceMesh& mesh) {
  for (Index t = 0; t < mesh.triangle_count(); ++t) flip(mesh, t);
}

/// `a` followed by `b`, as one mesh.
SurfaceMesh join(const SurfaceMesh& a, const SurfaceMesh& b) {
  SurfaceMesh out;
  out.positions.resize(3, a.positions.cols() + b.positions.cols());
  out.positions << a.positions, b.positions;
  out.triangles.resize(3, a.triangles.cols() + b.triangles.cols());
  out.triangles << a.triangles, (b.triangles.array() + static_cast<Index>(a.vertex_count())).matrix();
  return out;
}

SurfaceMesh bunny() { return import_render_mesh(testing::data_dir() / "meshes" / "bunny-5k.obj").mesh; }

TEST(SurfaceOrientation, AConsistentClosedSurfaceIsLeftAlone) {
  SurfaceMesh mesh = bunny();
  const SurfaceMesh before = mesh;
  const OrientationRepair r = orient_surface(mesh);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.flipped(), 0u);
  EXPECT_EQ(mesh.triangles, before.triangles);
}

TEST(SurfaceOrientation, StrayFlippedTrianglesAreTurnedBackAndOnlyThey) {
  SurfaceMesh mesh = bunny();
  const SurfaceMesh before = mesh;
  for (Index t : {Index{7}, Index{1000}, Index{4321}}) flip(mesh, t);
  const OrientationRepair r = orient_surface(mesh);
  EXPECT_EQ(r.flipped_to_agree, 3u);
  EXPECT_EQ(r.inside_out_pieces, 0u);
  EXPECT_EQ(mesh.triangles, before.triangles);
}

TEST(SurfaceOrientation, AnInsideOutSurfaceIsTurnedRightSideOut) {
  SurfaceMesh mesh = bunny();
  const SurfaceMesh before = mesh;
  flip_all(mesh);
  flip(mesh, 99);  // and one stray triangle, which agrees with the original
  const OrientationRepair r = orient_surface(mesh);
  EXPECT_EQ(r.flipped_to_agree, 1u);
  EXPECT_EQ(r.inside_out_pieces, 1u);
  EXPECT_EQ(r.flipped_inside_out, before.triangle_count());
  EXPECT_EQ(mesh.triangles, before.triangles);
}

TEST(SurfaceOrientation, ACavityKeepsItsInwardOrientationAndAnInsideOutNeighbourIsTurned) {
  // A hollow ball (outer sphere out, inner sphere in: a cavity), and beside it a second
  // ball that is inside out.
  SurfaceMesh cavity = testing::icosphere(2, 0.5);
  flip_all(cavity);
  SurfaceMesh neighbour = testing::icosphere(2, 1.0, Vec3(3, 0, 0));
  flip_all(neighbour);
  SurfaceMesh mesh = join(join(testing::icosphere(2, 1.0), cavity), neighbour);
  const OrientationRepair r = orient_surface(mesh);
  EXPECT_EQ(r.components, 3u);
  EXPECT_EQ(r.flipped_to_agree, 0u);
  EXPECT_EQ(r.inside_out_pieces, 1u);
  EXPECT_EQ(r.flipped_inside_out, neighbour.triangle_count());
  const Index first_neighbour = static_cast<Index>(mesh.triangle_count() - neighbour.triangle_count());
  const Index first_cavity = first_neighbour - static_cast<Index>(cavity.triangle_count());
  const Index offset = static_cast<Index>(testing::icosphere(2).vertex_count());
  const Eigen::Matrix<Index, 3, 1> expected = (cavity.triangles.col(0).array() + offset).matrix();
  EXPECT_EQ(mesh.triangles.col(first_cavity), expected);
}

TEST(SurfaceOrientation, AMobiusStripIsReportedAndLeftAsItIs) {
  // A strip of 2n triangles closed with a half twist: no orientation is consistent.
  constexpr int n = 12;
  SurfaceMesh mesh;
  mesh.positions.resize(3, 2 * n);
  for (int i = 0; i < n; ++i) {
    const double u = 2 * M_PI * i / n;
    for (int side = 0; side < 2; ++side) {
      const double v = side ? 0.3 : -0.3;
      mesh.positions.col(2 * i + side) = Vec3((1 + v * std::cos(u / 2)) * std::cos(u), (1 + v * std::cos(u / 2)) * std::sin(u), v * std::sin(u / 2));
    }
  }
  mesh.triangles.resize(3, 2 * n);
  for (int i = 0; i < n; ++i) {
    const bool last = i == n - 1;
    const Index a = 2 * i, b = 2 * i + 1;
    const Index c = last ? 1 : 2 * i + 2, d = last ? 0 : 2 * i + 3;  // the twist swaps the sides
    mesh.triangles.col(2 * i) << a, c, b;
    mesh.triangles.col(2 * i + 1) << b, c, d;
  }
  const SurfaceMesh before = mesh;
  const OrientationRepair r = orient_surface(mesh);
  EXPECT_EQ(r.non_orientable, 1u);
  EXPECT_EQ(r.flipped(), 0u);
  EXPECT_EQ(mesh.triangles, before.triangles);
}

TEST(SelfIntersections, CleanSurfacesHaveNone) {
  EXPECT_EQ(count_self_intersections(bunny()), 0u);
  EXPECT_EQ(count_self_intersections(testing::torus(1.0, 0.3, 24, 12)), 0u);
  // Touching along a shared edge or vertex is not crossing, even when flat.
  EXPECT_EQ(count_self_intersections(testing::box_surface(Vec3::Zero(), Vec3::Ones(), 3)), 0u);
}

TEST(SelfIntersections, CountsCrossingsFoldsAndDuplicates) {
  SurfaceMesh mesh;
  mesh.positions.resize(3, 7);
  mesh.positions << 0, 1, 0, 0.2, 0.2, 1, 0.5,  //
      0, 0, 1, 0.2, 0.2, 1, 0.5,                 //
      0, 0, 0, -1, 1, 0, 0;
  mesh.triangles.resize(3, 1);
  mesh.triangles << 0, 1, 2;
  SurfaceMesh crossing = mesh;  // a second triangle piercing the first, sharing no corner
  crossing.triangles.conservativeResize(3, 2);
  crossing.triangles.col(1) << 3, 4, 5;
  crossing.positions.col(4) = Vec3(0.3, 0.1, 1);
  EXPECT_EQ(count_self_intersections(crossing), 1u);
  SurfaceMesh fold = mesh;  // sharing edge 0–1, folded flat onto the same side
  fold.triangles.conservativeResize(3, 2);
  fold.triangles.col(1) << 1, 0, 6;
  EXPECT_EQ(count_self_intersections(fold), 1u);
  fold.positions.col(6) = Vec3(0.5, -0.5, 0);  // unfolded: the other side, flat
  EXPECT_EQ(count_self_intersections(fold), 0u);
  SurfaceMesh shared_corner = mesh;  // sharing corner 0, the other one piercing it
  shared_corner.triangles.conservativeResize(3, 2);
  shared_corner.triangles.col(1) << 0, 3, 4;
  shared_corner.positions.col(3) = Vec3(0.3, 0.3, -1);
  shared_corner.positions.col(4) = Vec3(0.3, 0.3, 1);
  EXPECT_EQ(count_self_intersections(shared_corner), 1u);
  SurfaceMesh twice = mesh;
  twice.triangles.conservativeResize(3, 2);
  twice.triangles.col(1) << 2, 0, 1;
  EXPECT_EQ(count_self_intersections(twice), 1u);
}

TEST(SelfIntersections, TwoInterpenetratingSpheresCrossAlongACircle) {
  const SurfaceMesh mesh = join(testing::icosphere(3, 1.0), testing::icosphere(3, 1.0, Vec3(1, 0, 0)));
  EXPECT_GT(count_self_intersections(mesh), 20u);
}

}  // namespace
}  // namespace fissure::bake
