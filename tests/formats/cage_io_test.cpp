#include "formats/cage_io.h"

#include <gtest/gtest.h>

#include "common/error.h"
#include "tests/support/procedural.h"
#include "tests/support/temp_dir.h"

namespace fissure::formats {
namespace {

using testing::expect_error_containing;
using testing::TempDir;

// Two tets sharing face (1,2,3); the second is written negatively oriented.
constexpr const char* kNode0 = "5 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n4 1 1 1\n";
constexpr const char* kEle0 = "2 4 0\n0 0 1 2 3\n1 1 3 2 4\n";

void expect_two_tet_cage(const CageFile& cage) {
  ASSERT_EQ(cage.mesh.node_count(), 5u);
  ASSERT_EQ(cage.mesh.tet_count(), 2u);
  for (Index t = 0; t < 2; ++t) EXPECT_GT(signed_volume(cage.mesh, t), 0.0);
  EXPECT_EQ(cage.mesh.rest_positions.col(4), Vec3(1, 1, 1));
}

TEST(TetGenReader, ReadsZeroBasedAndReorients) {
  TempDir dir;
  dir.write("c.node", kNode0);
  const CageFile cage = read_cage(dir.write("c.ele", kEle0));
  expect_two_tet_cage(cage);
  EXPECT_EQ(cage.flipped_tets, 1u);
  EXPECT_EQ(cage.format, "tetgen");
}

TEST(TetGenReader, ReadsOneBasedWithAttributesMarkersAndComments) {
  TempDir dir;
  dir.write("c.node",
            "# nodes\n5 3 1 1\n1 0 0 0 7.5 1\n2 1 0 0 7.5 0\n3 0 1 0 1 1\n4 0 0 1 1 0  # trailing\n5 1 1 1 0 0\n");
  dir.write("c.ele", "2 4 1\n1 1 2 3 4 9\n2 2 3 4 5 9\n");
  expect_two_tet_cage(read_cage(dir / "c.node"));
}

TEST(TetGenReader, TakesCornersOfTenNodeTets) {
  TempDir dir;
  dir.write("c.node", kNode0);
  dir.write("c.ele", "1 10 0\n0 0 1 2 3 4 4 4 4 4 4\n");
  const CageFile cage = read_cage(dir / "c.ele");
  EXPECT_EQ(cage.mesh.tet_count(), 1u);
}

TEST(TetGenReader, OutOfRangeNodeNamesFileLineAndTet) {
  TempDir dir;
  dir.write("c.node", kNode0);
  dir.write("c.ele", "2 4 0\n0 0 1 2 3\n1 1 2 3 9\n");
  expect_error_containing([&] { read_cage(dir / "c.node"); }, {"c.ele:3", "tet 1", "node 9"});
}

TEST(TetGenReader, NonFiniteCoordinateNamesTheLine) {
  TempDir dir;
  dir.write("c.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 nan 0\n3 0 0 1\n");
  dir.write("c.ele", "1 4 0\n0 0 1 2 3\n");
  expect_error_containing([&] { read_cage(dir / "c.node"); }, {"c.node:4", "not finite"});
  dir.write("c.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 inf\n");
  expect_error_containing([&] { read_cage(dir / "c.node"); }, {"c.node:5", "not finite"});
}

TEST(TetGenReader, TruncatedFileIsAnError) {
  TempDir dir;
  dir.write("c.node", kNode0);
  dir.write("c.ele", "2 4 0\n0 0 1 2 3\n1 1 2\n");
  expect_error_containing([&] { read_cage(dir / "c.ele"); }, {"c.ele:1", "announces 2 tets", "truncated"});
  // A header far larger than the file: an error, not a huge allocation.
  dir.write("c.node", "1000000000000 3 0 0\n0 0 0 0\n");
  expect_error_containing([&] { read_cage(dir / "c.ele"); }, {"c.node:1", "announces 1000000000000 nodes", "truncated"});
  // A tet cut off mid-record after a plausible header.
  dir.write("c.node", kNode0);
  dir.write("c.ele", "1 4 0\n0 0 1 2\n");
  expect_error_containing([&] { read_cage(dir / "c.ele"); }, {"c.ele", "truncated"});
}

TEST(TetGenReader, DegenerateTetIsNamed) {
  TempDir dir;
  dir.write("c.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 1 1 0\n");
  dir.write("c.ele", "1 4 0\n1 1 2 3 4\n");
  expect_error_containing([&] { read_cage(dir / "c.ele"); }, {"tet 1", "degenerate"});
}

TEST(CageReader, MissingEmptyAndUnknownFilesAreErrors) {
  TempDir dir;
  expect_error_containing([&] { read_cage(dir / "none.node"); }, {"none.node", "not found"});
  dir.write("e.node", "  \n# only a comment\n");
  dir.write("e.ele", kEle0);
  expect_error_containing([&] { read_cage(dir / "e.node"); }, {"e.node", "empty"});
  expect_error_containing([&] { read_cage(dir.write("c.vtk", "x")); }, {"unknown cage format", ".vtk", ".msh"});
}

TEST(GmshReader, ReadsVersion22) {
  TempDir dir;
  const auto path = dir.write("c.msh",
                              "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"
                              "$PhysicalNames\n1\n3 1 \"solid\"\n$EndPhysicalNames\n"
                              "$Nodes\n5\n10 0 0 0\n11 1 0 0\n12 0 1 0\n13 0 0 1\n14 1 1 1\n$EndNodes\n"
                              "$Elements\n3\n1 2 2 0 1 10 11 12\n2 4 2 1 1 10 11 12 13\n3 4 2 1 1 11 12 13 14\n$EndElements\n");
  const CageFile cage = read_cage(path);
  EXPECT_EQ(cage.format, "gmsh-2.2");
  expect_two_tet_cage(cage);
}

TEST(GmshReader, ReadsVersion41) {
  TempDir dir;
  const auto path = dir.write("c.msh",
                              "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
                              "$Nodes\n2 5 1 5\n"
                              "0 1 0 1\n1\n0 0 0\n"
                              "3 1 0 4\n2\n3\n4\n5\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n$EndNodes\n"
                              "$Elements\n2 3 1 3\n"
                              "2 1 2 1\n1 1 2 3\n"
                              "3 1 4 2\n2 1 2 3 4\n3 2 3 4 5\n$EndElements\n");
  const CageFile cage = read_cage(path);
  EXPECT_EQ(cage.format, "gmsh-4.1");
  expect_two_tet_cage(cage);
}

TEST(GmshReader, RejectsBinaryOldVersionsAndDanglingNodes) {
  TempDir dir;
  expect_error_containing([&] { read_cage(dir.write("b.msh", "$MeshFormat\n4.1 1 8\n$EndMeshFormat\n")); },
                          {"binary", "-bin 0"});
  expect_error_containing([&] { read_cage(dir.write("o.msh", "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n")); },
                          {"version 3.0"});
  expect_error_containing(
      [&] {
        read_cage(dir.write("d.msh",
                            "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n"
                            "$EndNodes\n$Elements\n1\n1 4 0 1 2 3 7\n$EndElements\n"));
      },
      {"d.msh:", "element 1", "node 7"});
  expect_error_containing(
      [&] {
        read_cage(dir.write("s.msh",
                            "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n"
                            "$EndNodes\n$Elements\n1\n1 2 0 1 2 3\n$EndElements\n"));
      },
      {"no tetrahedra", "gmsh -3"});
}

TEST(MeditReader, ReadsVerticesAndTetrahedraSkippingSurfaces) {
  TempDir dir;
  const auto path = dir.write("c.mesh",
                              "MeshVersionFormatted 2\nDimension 3\n# comment\nVertices\n5\n0 0 0 1\n1 0 0 1\n0 1 0 1\n"
                              "0 0 1 1\n1 1 1 1\nTriangles\n1\n1 2 3 0\nTetrahedra\n2\n1 2 3 4 0\n2 3 4 5 0\nEnd\n");
  const CageFile cage = read_cage(path);
  EXPECT_EQ(cage.format, "medit");
  expect_two_tet_cage(cage);
}

TEST(MeditReader, BogusCountsAreErrorsNotAllocations) {
  TempDir dir;
  expect_error_containing([&] { read_cage(dir.write("big.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n4611686018427387904\n0 0 0 1\n")); },
                          {"big.mesh:4", "announces", "truncated"});
  expect_error_containing([&] { read_cage(dir.write("tri.mesh", "MeshVersionFormatted 2\nTriangles\n999999999999\n1 2 3 0\n")); },
                          {"tri.mesh:3", "announces"});
}

TEST(GmshReader, BogusCountsAreErrorsNotAllocations) {
  TempDir dir;
  expect_error_containing(
      [&] { read_cage(dir.write("big.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n99999999999\n1 0 0 0\n$EndNodes\n")); },
      {"big.msh:5", "announces"});
}

TEST(MeditReader, OutOfRangeVertexAndUnknownKeyword) {
  TempDir dir;
  expect_error_containing(
      [&] {
        read_cage(dir.write("c.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 1\n1 0 0 1\n0 1 0 1\n"
                                      "0 0 1 1\nTetrahedra\n1\n1 2 3 5 0\nEnd\n"));
      },
      {"c.mesh:", "tet 1", "vertex 5"});
  expect_error_containing([&] { read_cage(dir.write("k.mesh", "MeshVersionFormatted 2\nFoo 3\n")); },
                          {"unknown MEDIT keyword 'Foo'"});
}

TEST(CageReader, SharedSampleCagesAreValid) {
  for (const char* name : {"bunny-5k-cage-10.node", "bunny-5k-cage-100.node", "bunny-5k-cage-987.node"}) {
    const CageFile cage = read_cage(testing::data_dir() / "cages" / name);
    EXPECT_EQ(cage.flipped_tets, 0u) << name;  // the samples are positively oriented
    EXPECT_GT(cage.mesh.tet_count(), 0u);
  }
}

TEST(CageReader, TetGenWriteReadRoundTrip) {
  TempDir dir;
  const TetMesh grid = testing::grid_cage(Vec3::Zero(), Vec3(1, 2, 3), 2, 2, 2);
  write_tetgen(grid, dir / "g.node", dir / "g.ele");
  const CageFile cage = read_cage(dir / "g.node");
  EXPECT_EQ(cage.mesh.rest_positions, grid.rest_positions);
  EXPECT_EQ(cage.mesh.tets, grid.tets);
}

}  // namespace
}  // namespace fissure::formats
