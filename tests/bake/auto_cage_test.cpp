// Automatic lattice cages (issue 43): containment, count, shape, pieces, determinism,
// bad input.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>

#include "bake/auto_cage.h"
#include "bake/bake.h"
#include "bake/cage_quality.h"
#include "bake/lattice_cage.h"
#include "bake/mesh_import.h"
#include "bake/winding_number.h"
#include "common/error.h"
#include "tests/support/procedural.h"
#include "tests/support/temp_dir.h"

namespace fissure::bake {
namespace {

using testing::expect_error_containing;

SurfaceMesh bunny() { return import_render_mesh(testing::data_dir() / "meshes" / "bunny-5k.obj", {}).mesh; }

AutoCageOptions asking(std::size_t tets) {
  AutoCageOptions options;
  options.tets = tets;
  return options;
}

/// Two meshes in one: the second's triangles after the first's.
SurfaceMesh joined(const SurfaceMesh& a, const SurfaceMesh& b) {
  SurfaceMesh m;
  m.positions.resize(3, a.positions.cols() + b.positions.cols());
  m.positions << a.positions, b.positions;
  m.triangles.resize(3, a.triangles.cols() + b.triangles.cols());
  m.triangles << a.triangles, (b.triangles.array() + static_cast<Index>(a.vertex_count())).matrix();
  return m;
}

// The Kuhn simplex of a cube has dihedral angles 45°, 45°, 60°, 90°, 90°, 90°: every
// lattice tet is congruent to it, so 45° is the minimum at any count, far above 10°.
TEST(LatticeCage, KuhnTetsHaveDihedralAnglesOf45To90Degrees) {
  auto angles = dihedral_angles_deg(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(1, 1, 1));
  std::sort(angles.begin(), angles.end());
  const double expected[6] = {45, 45, 60, 90, 90, 90};
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(angles[static_cast<std::size_t>(i)], expected[i], 1e-9);
  // A sliver: four nearly coplanar points have angles near 0° and 180°.
  const auto sliver = dihedral_angles_deg(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(1, 1, 1e-3));
  EXPECT_LT(*std::min_element(sliver.begin(), sliver.end()), 1.0);
}

// Count within ±15 % across the range, containment checked exactly by the bake's own
// coverage stage, one piece, and the shape bound, on the bunny.
TEST(LatticeCage, BunnyCagesLandWithin15PercentContainItAndKeep45Degrees) {
  const SurfaceMesh mesh = bunny();
  for (const std::size_t asked : {50u, 300u, 2000u, 20000u}) {
    const AutoCage cage = make_cage(mesh, asking(asked), "bunny");
    const double made = static_cast<double>(cage.mesh.tet_count());
    EXPECT_LE(std::abs(made / static_cast<double>(asked) - 1.0), 0.15) << asked << " asked, " << made << " made";
    EXPECT_NO_THROW(check_cage_covers(mesh, cage.mesh, "bunny", "lattice")) << asked;
    const CageQuality q = measure_cage(mesh, cage.mesh);
    EXPECT_GE(q.min_dihedral_deg, 45.0 - 1e-9) << asked;
    EXPECT_LE(q.max_dihedral_deg, 90.0 + 1e-9) << asked;
    EXPECT_EQ(q.degenerate_tets, 0u);
    EXPECT_EQ(q.pieces, 1u) << asked;
    EXPECT_GT(q.cage_volume, q.solid_volume) << asked;
  }
}

// The check that guards every written cage can fail: a cage missing one cube that the
// surface passes through is refused.
TEST(LatticeCage, TheContainmentCheckRefusesACageWithACubeMissing) {
  const SurfaceMesh mesh = bunny();
  AutoCage cage = make_cage(mesh, asking(1000), "bunny");
  TetMesh holed = cage.mesh;
  // Drop the 6 tets of the first cube (cubes come in grid order, their tets in sixes);
  // the lowest cube of the grid that is kept holds surface.
  holed.tets = cage.mesh.tets.rightCols(cage.mesh.tets.cols() - 6);
  expect_error_containing([&] { check_cage_covers(mesh, holed, "bunny", "holed"); }, {"holed does not cover bunny"});
}

// Surface lying exactly in the grid's planes (a box whose faces are lattice planes) is
// still inside: the cubes on both sides of a plane it lies in are kept.
TEST(LatticeCage, SurfaceInTheGridPlanesIsContained) {
  const SurfaceMesh box = testing::box_surface(Vec3(0, 0, 0), Vec3(1, 1, 1), 3);
  const WindingNumberTree winding(box);
  LatticeGrid grid;
  grid.cell = 0.25;
  grid.phase = Vec3::Zero();  // the grid starts at the box's corner: its faces are grid planes
  const LatticeCage cage = build_lattice_cage(box, winding, grid);
  EXPECT_GE(cage.cubes, 64u);
  EXPECT_NO_THROW(check_cage_covers(box, cage.mesh, "box", "lattice"));
}

// Cubes that meet only along an edge are joined through the cube between them; parts
// farther apart stay separate pieces.
TEST(LatticeCage, DiagonalNeighboursAreJoinedAndDistantPartsStayApart) {
  const SurfaceMesh diagonal = joined(testing::icosphere(1, 0.1, Vec3(0.5, 0.5, 0.5)), testing::icosphere(1, 0.1, Vec3(1.5, 1.5, 0.5)));
  const WindingNumberTree winding(diagonal);
  LatticeGrid grid;
  grid.cell = 1.0;  // the box 0.4…1.6 centred: planes at 0, 1, 2; the spheres in cubes (0,0) and (1,1)
  const LatticeCage cage = build_lattice_cage(diagonal, winding, grid);
  EXPECT_EQ(cage.cubes, 3u);
  EXPECT_EQ(cage.bridge_cubes, 1u);
  EXPECT_EQ(measure_cage(diagonal, cage.mesh).pieces, 1u);

  const SurfaceMesh apart = joined(testing::icosphere(2, 1.0), testing::icosphere(2, 1.0, Vec3(6, 0, 0)));
  const AutoCage two = make_cage(apart, asking(400), "two spheres");
  EXPECT_EQ(measure_cage(apart, two.mesh).pieces, 2u);
  EXPECT_NO_THROW(check_cage_covers(apart, two.mesh, "two spheres", "lattice"));
}

// A small count of a symmetric shape moves in steps of several cubes; where no cubic
// grid lands within 15 %, the search stretches the cells (each axis 0.9 … 1.1 of the
// cell), which keeps every dihedral angle at or above 39.2°.
TEST(LatticeCage, WhereNoCubicGridLandsStretchedCellsDoAndKeep39Degrees) {
  const SurfaceMesh apart = joined(testing::icosphere(2, 1.0), testing::icosphere(2, 1.0, Vec3(6, 0, 0)));
  const WindingNumberTree winding(apart);
  std::size_t tries = 0;
  const LatticeGrid grid = search_lattice_grid(apart, winding, 500, 0.15, &tries);
  EXPECT_NE(grid.stretch, Vec3::Ones()) << "a cubic grid landed: the case no longer tests the stretch";
  const LatticeCage cage = build_lattice_cage(apart, winding, grid);
  EXPECT_LE(std::abs(static_cast<double>(cage.mesh.tet_count()) / 500.0 - 1.0), 0.15) << cage.mesh.tet_count();
  EXPECT_GE(measure_cage(apart, cage.mesh).min_dihedral_deg, 39.2);
  EXPECT_NO_THROW(check_cage_covers(apart, cage.mesh, "two spheres", "lattice"));
}

// A torus keeps its hole (genus 1) at a count where the hole is several cells wide.
TEST(LatticeCage, ATorusKeepsItsHole) {
  const SurfaceMesh torus = testing::torus(1.0, 0.25, 48, 16);
  const AutoCage cage = make_cage(torus, asking(3000), "torus");
  EXPECT_NO_THROW(check_cage_covers(torus, cage.mesh, "torus", "lattice"));
  // No tet near the axis: the cage does not fill the hole.
  for (Index n = 0; n < cage.mesh.node_count(); ++n) {
    EXPECT_GT(cage.mesh.rest_positions.col(n).head<2>().norm(), 0.5) << "node " << n;
  }
}

TEST(LatticeCage, TheSameMeshGivesTheSameCageAtAnyThreadCount) {
  const SurfaceMesh mesh = bunny();
  AutoCage one, two;
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = make_cage(mesh, asking(2000), "bunny");
  }
  two = make_cage(mesh, asking(2000), "bunny");
  EXPECT_EQ(one.mesh.rest_positions, two.mesh.rest_positions);
  EXPECT_EQ(one.mesh.tets, two.mesh.tets);
  EXPECT_EQ(one.cell, two.cell);
}

AutoCageOptions wrapping(std::size_t tets) {
  AutoCageOptions options = asking(tets);
  options.method = "wrap";
  return options;
}

// The wrap cage follows the shape (alpha wrap, then Mesh_3 with perturb and exude): it
// lands within ±15 %, holds the surface exactly, keeps every dihedral angle at or above
// 10° and has no degenerate tet, in one piece, within 2.5× the solid's volume; at 300
// tets it is tighter than the lattice of the same count.
TEST(WrapCage, BunnyCagesLandContainItAndKeep10Degrees) {
  const SurfaceMesh mesh = bunny();
  for (const std::size_t asked : {300u, 2000u}) {
    const AutoCage cage = make_cage(mesh, wrapping(asked), "bunny");
    const double made = static_cast<double>(cage.mesh.tet_count());
    EXPECT_LE(std::abs(made / static_cast<double>(asked) - 1.0), 0.15) << asked << " asked, " << made << " made";
    EXPECT_NO_THROW(check_cage_covers(mesh, cage.mesh, "bunny", "wrap")) << asked;
    const CageQuality q = measure_cage(mesh, cage.mesh);
    EXPECT_GE(q.min_dihedral_deg, 10.0) << asked;
    EXPECT_EQ(q.degenerate_tets, 0u);
    EXPECT_EQ(q.pieces, 1u) << asked;
    EXPECT_LT(q.cage_volume, 2.5 * q.solid_volume) << asked;
    if (asked == 300) {
      EXPECT_LT(q.cage_volume, measure_cage(mesh, make_cage(mesh, asking(asked), "bunny").mesh).cage_volume);
    }
  }
}

// A plate 100 times thinner than wide: even the coarsest envelope tried needs twice the
// tets asked. A clear error that points at the lattice, which takes any shape.
TEST(WrapCage, AnEnvelopeThatNeedsMoreTetsThanAskedNamesTheLattice) {
  const SurfaceMesh plate = testing::box_surface(Vec3(0, 0, 0), Vec3(1, 1, 0.01), 2);
  expect_error_containing([&] { make_cage(plate, wrapping(500), "plate"); },
                          {"no wrap cage lands within ±15 % of --tets 500", "--method lattice"});
  EXPECT_NO_THROW(make_cage(plate, asking(500), "plate"));
}

TEST(WrapCage, TheSameMeshGivesTheSameCageAtAnyThreadCount) {
  const SurfaceMesh mesh = bunny();
  AutoCage one, two;
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = make_cage(mesh, wrapping(500), "bunny");
  }
  two = make_cage(mesh, wrapping(500), "bunny");
  EXPECT_EQ(one.mesh.rest_positions, two.mesh.rest_positions);
  EXPECT_EQ(one.mesh.tets, two.mesh.tets);
}

TEST(LatticeCage, BadInputIsAClearError) {
  expect_error_containing([] { make_cage(SurfaceMesh{}, asking(100), "empty.obj"); }, {"empty.obj", "no triangles"});
  SurfaceMesh flat;
  flat.positions = Matrix3Xd::Identity(3, 3);
  flat.triangles = Matrix3Xu(3, 1);
  flat.triangles << 0, 1, 2;
  expect_error_containing([&] { make_cage(flat, asking(100), "flat.obj"); }, {"flat.obj", "flat", "one plane"});
  SurfaceMesh collinear = flat;
  collinear.positions.col(2) = 2.0 * collinear.positions.col(1) - collinear.positions.col(0);
  expect_error_containing([&] { make_cage(collinear, asking(100), "line.obj"); }, {"line.obj", "zero area"});
  const SurfaceMesh sphere = testing::icosphere(2);
  expect_error_containing([&] { make_cage(sphere, asking(0), "s"); }, {"--tets 0", "out of range"});
  expect_error_containing([&] { make_cage(sphere, asking(1'000'000'000), "s"); }, {"--tets 1000000000", "out of range"});
  AutoCageOptions voxel = asking(100);
  voxel.method = "voxel";
  expect_error_containing([&] { make_cage(sphere, voxel, "s"); }, {"--method voxel", "lattice", "wrap"});
}

TEST(LatticeCage, TetCountsParseAsTyped) {
  EXPECT_EQ(parse_tet_count("1000"), 1000u);
  EXPECT_EQ(parse_tet_count("1e3"), 1000u);
  expect_error_containing([] { parse_tet_count("0"); }, {"--tets 0", "out of range"});
  expect_error_containing([] { parse_tet_count("1e9"); }, {"--tets 1e9", "out of range"});
  expect_error_containing([] { parse_tet_count("12.5"); }, {"not a whole number"});
  expect_error_containing([] { parse_tet_count("nan"); }, {"not a whole number"});
  expect_error_containing([] { parse_tet_count("many"); }, {"not a whole number"});
}

}  // namespace
}  // namespace fissure::bake
