#include "bake/mesh_import.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>

#include "common/error.h"
#include "tests/support/procedural.h"
#include "tests/support/temp_dir.h"

namespace fissure::bake {
namespace {

using testing::expect_error_containing;
using testing::TempDir;

constexpr const char* kCubeWithNormals =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    "vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 0 1 0\nvn -1 0 0\nvn 1 0 0\n"
    "f 1//1 3//1 2//1\nf 1//1 4//1 3//1\nf 5//2 6//2 7//2\nf 5//2 7//2 8//2\n"
    "f 1//3 2//3 6//3\nf 1//3 6//3 5//3\nf 4//4 8//4 7//4\nf 4//4 7//4 3//4\n"
    "f 1//5 5//5 8//5\nf 1//5 8//5 4//5\nf 2//6 3//6 7//6\nf 2//6 7//6 6//6\n";

TEST(MeshImport, ReadsTheSampleBunnyWithItsIndexing) {
  const ImportedMesh imported = import_render_mesh(testing::data_dir() / "meshes" / "bunny-5k.obj");
  EXPECT_EQ(imported.mesh.vertex_count(), 2502u);
  EXPECT_EQ(imported.mesh.triangle_count(), 5000u);
  EXPECT_TRUE(analyze_topology(imported.mesh).closed());
}

TEST(MeshImport, KeepsNormalSeamsUnlessWelding) {
  TempDir dir;
  const auto path = dir.write("cube.obj", kCubeWithNormals);
  const ImportedMesh split = import_render_mesh(path);
  EXPECT_EQ(split.mesh.triangle_count(), 12u);
  EXPECT_EQ(split.mesh.vertex_count(), 24u);  // 8 corners × 3 face normals
  ASSERT_EQ(split.mesh.normals.cols(), 24);
  const ImportedMesh welded = import_render_mesh(path, MeshImportOptions{.weld = true});
  EXPECT_EQ(welded.mesh.vertex_count(), 8u);
  EXPECT_EQ(welded.mesh.triangle_count(), 12u);
  EXPECT_TRUE(analyze_topology(welded.mesh).closed());
}

TEST(MeshImport, MergesAllMeshesOfAScene) {
  TempDir dir;
  const auto path = dir.write("two.obj",
                              "o first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
                              "o second\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 4 5 6\n");
  const ImportedMesh imported = import_render_mesh(path);
  EXPECT_EQ(imported.source_meshes, 2u);
  EXPECT_EQ(imported.mesh.triangle_count(), 2u);
  EXPECT_EQ(imported.mesh.vertex_count(), 6u);
}

TEST(MeshImport, ReadsPlyAndStl) {
  TempDir dir;
  const auto ply = dir.write("t.ply",
                             "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                             "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                             "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n");
  const ImportedMesh from_ply = import_render_mesh(ply);
  EXPECT_EQ(from_ply.mesh.triangle_count(), 2u);
  EXPECT_EQ(from_ply.mesh.vertex_count(), 4u);
  const auto stl = dir.write("t.stl",
                             "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nendloop\n"
                             "endfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\n"
                             "endfacet\nendsolid t\n");
  const ImportedMesh from_stl = import_render_mesh(stl);
  EXPECT_EQ(from_stl.mesh.triangle_count(), 2u);
  EXPECT_EQ(from_stl.mesh.vertex_count(), 4u);  // STL repeats corners; identical ones are joined
}

std::string base64(const std::vector<std::uint8_t>& bytes) {
  static constexpr char kTable[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::uint32_t n = (std::uint32_t{bytes[i]} << 16) | (i + 1 < bytes.size() ? std::uint32_t{bytes[i + 1]} << 8 : 0) |
                            (i + 2 < bytes.size() ? bytes[i + 2] : 0);
    out += kTable[(n >> 18) & 63];
    out += kTable[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? kTable[(n >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kTable[n & 63] : '=';
  }
  return out;
}

/// One triangle (0,0,0), (1,0,0), (0,1,0) (normal +z) in a glTF file whose node has
/// the given transform properties.
std::string one_triangle_gltf(const std::string& node_transform) {
  std::vector<std::uint8_t> buffer(36 + 8, 0);
  const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const std::uint16_t indices[3] = {0, 1, 2};
  std::memcpy(buffer.data(), positions, 36);
  std::memcpy(buffer.data() + 36, indices, 6);
  return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0,)" + node_transform +
         R"(}],"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],)"
         R"("buffers":[{"byteLength":44,"uri":"data:application/octet-stream;base64,)" +
         base64(buffer) +
         R"("}],"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],)"
         R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},)"
         R"({"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}]})";
}

Vec3 triangle_normal(const SurfaceMesh& mesh, Index t) {
  const Vec3 a = mesh.positions.col(mesh.triangles(0, t));
  return (mesh.positions.col(mesh.triangles(1, t)) - a).cross(mesh.positions.col(mesh.triangles(2, t)) - a);
}

TEST(MeshImport, ReadsGltfWithANodeTransform) {
  TempDir dir;
  const ImportedMesh imported = import_render_mesh(dir.write("t.gltf", one_triangle_gltf(R"("translation":[0,0,5])")));
  ASSERT_EQ(imported.mesh.triangle_count(), 1u);
  for (Index v = 0; v < 3; ++v) EXPECT_DOUBLE_EQ(imported.mesh.positions(2, v), 5.0);
  EXPECT_GT(triangle_normal(imported.mesh, 0).z(), 0.0);
}

TEST(MeshImport, MirroringTransformKeepsTrianglesFacingOutward) {
  // Scale x by −1: the triangle moves to x ≤ 0 and must keep its +z normal.
  TempDir dir;
  const ImportedMesh imported = import_render_mesh(dir.write("m.gltf", one_triangle_gltf(R"("scale":[-1,1,1])")));
  ASSERT_EQ(imported.mesh.triangle_count(), 1u);
  EXPECT_LE(imported.mesh.positions.row(0).maxCoeff(), 0.0);
  EXPECT_GT(triangle_normal(imported.mesh, 0).z(), 0.0);
}

TEST(MeshImport, BadInputsAreClearErrors) {
  TempDir dir;
  expect_error_containing([&] { import_render_mesh(dir / "nope.obj"); }, {"nope.obj", "not found"});
  expect_error_containing([&] { import_render_mesh(dir.write("empty.obj", "")); }, {"empty.obj", "empty"});
  expect_error_containing([&] { import_render_mesh(dir.write("m.xyz123", "v 0 0 0\n")); },
                          {"unknown mesh format", ".xyz123"});
  expect_error_containing([&] { import_render_mesh(dir.write("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n")); },
                          {"points.obj"});
  expect_error_containing([&] { import_render_mesh(dir.write("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")); },
                          {"range.obj"});
  // A binary STL whose header promises 100 triangles but holds one.
  std::string stl(80, ' ');
  const std::uint32_t count = 100;
  stl.append(reinterpret_cast<const char*>(&count), 4);
  stl.append(50, '\0');
  expect_error_containing([&] { import_render_mesh(dir.write("cut.stl", stl)); }, {"cut.stl"});
}

TEST(MeshImport, NonFiniteCoordinatesAreRejected) {
  TempDir dir;
  // Binary STL lets us store a real NaN, whatever the text parser makes of "nan".
  std::string stl(80, ' ');
  const std::uint32_t count = 1;
  stl.append(reinterpret_cast<const char*>(&count), 4);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float facet[12] = {0, 0, 1, 0, 0, 0, 1, nan, 0, 0, 1, 0};
  stl.append(reinterpret_cast<const char*>(facet), sizeof facet);
  stl.append(2, '\0');
  expect_error_containing([&] { import_render_mesh(dir.write("nan.stl", stl)); }, {"nan.stl", "non-finite"});
}

}  // namespace
}  // namespace fissure::bake
