#include "formats/cage_write.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <system_error>

#include "common/error.h"
#include "common/output_file.h"
#include "formats/cage_io.h"

namespace fissure::formats {
namespace {

/// "x y z" with 17 significant digits: the shortest text that reads back as the same double.
void append_point(std::string& out, const Matrix3Xd& positions, Eigen::Index i) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "%.17g %.17g %.17g", positions(0, i), positions(1, i), positions(2, i));
  out += buffer;
}

void append_tet(std::string& out, const Matrix4Xu& tets, Eigen::Index t, Index base) {
  for (int k = 0; k < 4; ++k) out += ' ' + std::to_string(tets(k, t) + base);
}

}  // namespace

std::string tetgen_node_text(const TetMesh& mesh) {
  std::string out = std::to_string(mesh.node_count()) + " 3 0 0\n";
  for (Eigen::Index i = 0; i < mesh.rest_positions.cols(); ++i) {
    out += std::to_string(i) + ' ';
    append_point(out, mesh.rest_positions, i);
    out += '\n';
  }
  return out;
}

std::string tetgen_ele_text(const TetMesh& mesh) {
  std::string out = std::to_string(mesh.tet_count()) + " 4 0\n";
  for (Eigen::Index t = 0; t < mesh.tets.cols(); ++t) {
    out += std::to_string(t);
    append_tet(out, mesh.tets, t, 0);
    out += '\n';
  }
  return out;
}

std::string gmsh_text(const TetMesh& mesh) {
  std::string out = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n" + std::to_string(mesh.node_count()) + "\n";
  for (Eigen::Index i = 0; i < mesh.rest_positions.cols(); ++i) {
    out += std::to_string(i + 1) + ' ';
    append_point(out, mesh.rest_positions, i);
    out += '\n';
  }
  out += "$EndNodes\n$Elements\n" + std::to_string(mesh.tet_count()) + "\n";
  for (Eigen::Index t = 0; t < mesh.tets.cols(); ++t) {
    out += std::to_string(t + 1) + " 4 2 0 1";  // type 4: 4-node tet; tags: physical 0, entity 1
    append_tet(out, mesh.tets, t, 1);
    out += '\n';
  }
  return out + "$EndElements\n";
}

std::string medit_text(const TetMesh& mesh) {
  std::string out = "MeshVersionFormatted 2\nDimension 3\nVertices\n" + std::to_string(mesh.node_count()) + "\n";
  for (Eigen::Index i = 0; i < mesh.rest_positions.cols(); ++i) {
    append_point(out, mesh.rest_positions, i);
    out += " 0\n";
  }
  out += "Tetrahedra\n" + std::to_string(mesh.tet_count()) + "\n";
  for (Eigen::Index t = 0; t < mesh.tets.cols(); ++t) {
    append_tet(out, mesh.tets, t, 1);
    out += " 0\n";
  }
  return out + "End\n";
}

bool is_cage_path(const std::filesystem::path& path) {
  const std::string ext = lowercase_extension(path);
  return ext == ".node" || ext == ".ele" || ext == ".msh" || ext == ".mesh";
}

void write_cage(const TetMesh& mesh, const std::filesystem::path& path) {
  const std::string ext = lowercase_extension(path);
  if (ext == ".msh") return write_file_atomically(path, gmsh_text(mesh));
  if (ext == ".mesh") return write_file_atomically(path, medit_text(mesh));
  if (ext != ".node" && ext != ".ele") {
    throw Error(path.string() + ": unknown cage format '" + ext + "'",
                "name the output .node (TetGen, writes .node and .ele), .msh (Gmsh 2.2) or .mesh (MEDIT)");
  }
  const auto files = cage_files(path);
  const std::string node = tetgen_node_text(mesh), ele = tetgen_ele_text(mesh);
  write_file_atomically(files[0], node);
  try {
    write_file_atomically(files[1], ele);
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove(files[0], ignored);  // never half a pair
    throw;
  }
}

}  // namespace fissure::formats
