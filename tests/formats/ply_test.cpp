// The PLY reader: the three encodings read the same mesh; every malformed file is an
// error naming the file and the line or element, found before any allocation.
#include "formats/ply.h"

#include <gtest/gtest.h>

#include <bit>
#include <cstring>

#include "common/error.h"

namespace fissure::formats {
namespace {

// A square (a fan of two triangles), a triangle, and an edge that cannot be embedded.
const std::string kHeaderTail =
    "property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
    "property float s\nproperty float t\nelement face 3\nproperty list uchar int vertex_indices\n"
    "element camera 1\nproperty float fov\nend_header\n";
const float kVertices[5][8] = {{0, 0, 0, 0, 0, 2, 0, 0},   {1, 0, 0, 0, 0, 1, 1, 0}, {1, 1, 0, 0, 0, 1, 1, 1},
                               {0, 1, 0, 0, 0, 1, 0, 1},   {0, 0, 1, 0, 0, 1, 0.5f, 0.5f}};
const std::vector<std::vector<int>> kFaces = {{0, 1, 2, 3}, {0, 1, 4}, {2, 4}};

std::string ascii_file() {
  std::string text = "ply\nformat ascii 1.0\ncomment made by a test\nelement vertex 5\n" + kHeaderTail;
  for (const auto& v : kVertices) {
    for (const float x : v) text += std::to_string(x) + " ";
    text += "\n";
  }
  for (const auto& f : kFaces) {
    text += std::to_string(f.size());
    for (const int i : f) text += " " + std::to_string(i);
    text += "\n";
  }
  return text + "45\n";
}

template <typename T>
void append(std::string& out, T value, bool big_endian) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if (big_endian == (std::endian::native == std::endian::little)) std::reverse(bytes, bytes + sizeof(T));
  out.append(bytes, sizeof(T));
}

std::string binary_file(bool big_endian) {
  std::string out = std::string("ply\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") +
                    " 1.0\nelement vertex 5\n" + kHeaderTail;
  for (const auto& v : kVertices) {
    for (const float x : v) append(out, x, big_endian);
  }
  for (const auto& f : kFaces) {
    append(out, static_cast<std::uint8_t>(f.size()), big_endian);
    for (const int i : f) append(out, i, big_endian);
  }
  append(out, 45.0f, big_endian);
  return out;
}

void expect_error(const std::string& bytes, std::initializer_list<std::string> parts) {
  try {
    parse_ply(bytes, "m.ply");
    ADD_FAILURE() << "accepted:\n" << bytes.substr(0, 300);
  } catch (const Error& e) {
    for (const auto& part : parts) EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    EXPECT_FALSE(e.hint().empty()) << e.what();
  }
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

TEST(Ply, TheThreeEncodingsReadTheSameMeshWithPolygonsAsFans) {
  const PlyMesh ascii = parse_ply(ascii_file(), "a.ply");
  ASSERT_EQ(ascii.mesh.vertex_count(), 5U);
  ASSERT_EQ(ascii.mesh.triangle_count(), 3U);
  EXPECT_EQ(ascii.skipped_faces, 1U);
  Matrix3Xu expected(3, 3);
  expected << 0, 0, 0, 1, 2, 1, 2, 3, 4;
  EXPECT_EQ(ascii.mesh.triangles, expected);
  EXPECT_EQ(ascii.mesh.normals.col(0), Vec3(0, 0, 1)) << "normals are made unit";
  EXPECT_EQ(ascii.mesh.uvs.col(4), Vec2(0.5, 0.5));
  for (const bool big_endian : {false, true}) {
    const PlyMesh binary = parse_ply(binary_file(big_endian), "b.ply");
    EXPECT_EQ(binary.mesh.positions, ascii.mesh.positions);
    EXPECT_EQ(binary.mesh.triangles, ascii.mesh.triangles);
    EXPECT_EQ(binary.mesh.normals, ascii.mesh.normals);
    EXPECT_EQ(binary.mesh.uvs, ascii.mesh.uvs);
  }
}

TEST(Ply, AHeaderWithoutEndIsAnErrorNotAHang) {
  expect_error("ply\nformat ascii 1.0\n", {"m.ply", "no 'end_header'"});
  expect_error("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n" + std::string(2 << 20, ' ') + "\n",
               {"no 'end_header' line in its first 1 MiB"});
  expect_error("plx\n", {"not a PLY file"});
}

TEST(Ply, CountsTheFileCannotHoldFailBeforeAnyAllocation) {
  expect_error(replaced(ascii_file(), "element vertex 5", "element vertex 5000000000"), {"m.ply:4", "below 2^32-1"});
  expect_error(replaced(ascii_file(), "element vertex 5", "element vertex 400000000"),
               {"m.ply:4", "'vertex' claims 400000000 entries, more than the"});
  std::string binary = binary_file(false);
  binary[binary.find("end_header\n") + 11 + 5 * 32] = static_cast<char>(250);  // the first face's count
  expect_error(binary, {"property 'vertex_indices' of face 0 claims a list of 250 items"});
  expect_error(replaced(ascii_file(), "4 0 1 2 3", "100000000 0 1 2 3"), {"m.ply:", "list of 100000000 items"});
}

TEST(Ply, BadValuesNameTheLineOrElement) {
  expect_error(replaced(ascii_file(), "3 0 1 4", "3 0 1 9"), {"face 1 references vertex 9 but the file has 5"});
  expect_error(replaced(ascii_file(), "3 0 1 4", "3 0 -1 4"), {"m.ply:", "face 1 holds the vertex index -1"});
  expect_error(replaced(ascii_file(), "3 0 1 4", "3 0 1.5 4"), {"not an integer"});
  expect_error(replaced(ascii_file(), "1.000000 0.000000 0.000000", "1.000000 nan 0.000000"),
               {"vertex 1 has a non-finite coordinate"});
  expect_error(replaced(ascii_file(), "1.000000 0.000000 0.000000", "1.000000 zero 0.000000"),
               {"m.ply:", "'zero' is not a number"});
  expect_error(replaced(ascii_file(), "property float y", "property quad y"), {"m.ply:6", "unknown property type 'quad'"});
  expect_error(replaced(ascii_file(), "format ascii 1.0", "format ascii 2.0"), {"m.ply:2"});
  expect_error(replaced(ascii_file(), "vertex_indices", "corners"), {"no 'face' element with a vertex_indices list"});
  expect_error(ascii_file().substr(0, ascii_file().size() - 12), {"the file ends before"});
}

// Bytes from a damaged file are shown escaped: a NUL inside a token used to end the
// message there, and control bytes went to the terminal as they were.
TEST(Ply, RawBytesInAMessageAreEscapedNotEchoed) {
  expect_error(replaced(ascii_file(), "property float y", std::string("prop\0erty float y", 18)),
               {"m.ply:6: unknown header line 'prop\\x00erty'"});
  expect_error(replaced(ascii_file(), "1.000000 0.000000 0.000000", "1.000000 \x1b[2J 0.000000"),
               {"m.ply:", "'\\x1b[2J' is not a number"});
}

}  // namespace
}  // namespace fissure::formats
