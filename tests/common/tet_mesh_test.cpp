#include "common/tet_mesh.h"

#include <gtest/gtest.h>

#include "common/error.h"
#include "tests/support/procedural.h"

namespace fissure {
namespace {

TetMesh single_tet() {
  TetMesh mesh;
  mesh.rest_positions.resize(3, 4);
  mesh.rest_positions << 0, 1, 0, 0,  //
      0, 0, 1, 0,                     //
      0, 0, 0, 1;
  mesh.tets.resize(4, 1);
  mesh.tets << 0, 1, 2, 3;
  return mesh;
}

TEST(TetMesh, ReferenceTetHasVolumeOneSixth) { EXPECT_DOUBLE_EQ(signed_volume(single_tet(), 0), 1.0 / 6.0); }

TEST(TetMesh, LocalFacesPointOutward) {
  const TetMesh mesh = single_tet();
  const Vec3 centroid = mesh.rest_positions.rowwise().mean();
  for (const auto& face : kTetFaceNodes) {
    const Vec3 a = mesh.rest_positions.col(face[0]);
    const Vec3 normal = (mesh.rest_positions.col(face[1]) - a).cross(mesh.rest_positions.col(face[2]) - a);
    EXPECT_LT(normal.dot(centroid - a), 0.0);
  }
}

TEST(TetMesh, NegativeTetsAreFlipped) {
  TetMesh mesh = single_tet();
  std::swap(mesh.tets(0, 0), mesh.tets(1, 0));
  EXPECT_LT(signed_volume(mesh, 0), 0.0);
  EXPECT_EQ(validate_and_orient(mesh, "test"), 1u);
  EXPECT_GT(signed_volume(mesh, 0), 0.0);
}

TEST(TetMesh, DegenerateTetIsAnErrorNamingIt) {
  TetMesh mesh = single_tet();
  mesh.rest_positions.col(3) << 0.5, 0.5, 0.0;  // coplanar with the others
  try {
    validate_and_orient(mesh, "cage.ele", 1);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cage.ele: tet 1 is degenerate"), std::string::npos) << e.what();
  }
}

// TetGen numbers tets and nodes each from 0 or 1: a flat tet names its four nodes in the
// .node file's numbering, and a bad coordinate names the .node file, not the .ele.
TEST(TetMesh, ErrorsNameTheFileAndNumberingOfTheNodes) {
  TetMesh mesh = single_tet();
  mesh.rest_positions.col(3) << 0.5, 0.5, 0.0;
  const CageSource source{"cage.1.ele", "cage.1.node", 0, 1};
  try {
    validate_and_orient(mesh, source);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cage.1.ele: tet 0 is degenerate"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nodes 1, 2, 3, 4 of cage.1.node are (nearly) coplanar"), std::string::npos) << e.what();
  }
  mesh.rest_positions(1, 2) = std::numeric_limits<double>::infinity();
  try {
    validate_and_orient(mesh, source);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cage.1.node: node 3 has a non-finite coordinate"), std::string::npos) << e.what();
  }
}

TEST(TetMesh, OutOfRangeAndRepeatedNodesAreErrors) {
  TetMesh mesh = single_tet();
  mesh.tets(3, 0) = 4;
  EXPECT_THROW(validate_and_orient(mesh, "x"), Error);
  mesh.tets(3, 0) = 0;
  EXPECT_THROW(validate_and_orient(mesh, "x"), Error);
}

TEST(TetMesh, NonFiniteCoordinateIsAnError) {
  TetMesh mesh = single_tet();
  mesh.rest_positions(1, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(validate_and_orient(mesh, "x"), Error);
}

TEST(CageFaces, GridCageCountsMatchEulerFormula) {
  const int n = 3;
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3::Ones(), n, n, n);
  const CageFaces faces = build_cage_faces(cage, "grid");
  // 4 faces per tet, each interior face counted twice; boundary: 6 sides × n² squares × 2.
  const std::size_t boundary = 6 * n * n * 2;
  EXPECT_EQ(faces.face_count(), (4 * cage.tet_count() + boundary) / 2);
  std::size_t counted_boundary = 0;
  for (FaceIndex f = 0; f < faces.face_count(); ++f) counted_boundary += faces.is_boundary(f);
  EXPECT_EQ(counted_boundary, boundary);
}

TEST(CageFaces, TetFacesPointBackToTheirTets) {
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3::Ones(), 2, 2, 2);
  const CageFaces faces = build_cage_faces(cage, "grid");
  for (Index t = 0; t < cage.tet_count(); ++t) {
    for (int i = 0; i < 4; ++i) {
      const FaceIndex f = faces.tet_faces(i, t);
      EXPECT_TRUE(faces.tets(0, f) == t || faces.tets(1, f) == t);
    }
  }
}

TEST(CageFaces, TetsOnTheSameSideOfAFaceAreAnError) {
  // Two positive tets over face (0,1,2), both above it: they overlap.
  TetMesh mesh = single_tet();
  mesh.rest_positions.conservativeResize(3, 5);
  mesh.rest_positions.col(4) << 0.2, 0.2, 0.5;
  mesh.tets.resize(4, 2);
  mesh.tets << 0, 0,  //
      1, 1,           //
      2, 2,           //
      3, 4;
  ASSERT_EQ(validate_and_orient(mesh, "folded"), 0u);
  EXPECT_THROW(build_cage_faces(mesh, "folded"), Error);
}

TEST(CageFaces, FaceSharedByThreeTetsIsAnError) {
  TetMesh mesh = single_tet();
  mesh.rest_positions.conservativeResize(3, 6);
  mesh.rest_positions.col(4) << 0.3, 0.3, -1.0;
  mesh.rest_positions.col(5) << 0.3, 0.3, 0.5;
  mesh.tets.resize(4, 3);
  mesh.tets << 0, 0, 0,  //
      1, 2, 1,           //
      2, 1, 2,           //
      3, 4, 5;
  EXPECT_THROW(build_cage_faces(mesh, "bad"), Error);
}

}  // namespace
}  // namespace fissure
