#pragma once
/// Reading tetrahedral cages: TetGen .node/.ele (0- or 1-based, with or without
/// attributes and boundary markers), Gmsh .msh (2.2 and 4.1 ASCII) and MEDIT .mesh.
/// Every reader validates (finite coordinates, index ranges, non-degenerate tets) and
/// orients tets positively; errors name the file and the line or element.

#include <cstddef>
#include <filesystem>
#include <vector>
#include <string>

#include "common/tet_mesh.h"

namespace fissure::formats {

struct CageFile {
  TetMesh mesh;
  std::string format;              ///< "tetgen", "gmsh-2.2", "gmsh-4.1" or "medit"
  std::size_t flipped_tets = 0;    ///< tets that were negatively oriented in the file
  std::filesystem::path node_path; ///< file(s) actually read: the node file (or the one file)
  std::filesystem::path element_path; ///< the .ele file for TetGen, else equal to node_path
};

/// Reads a cage, picking the format from the extension: `.node` or `.ele` (the other
/// file of the pair is found beside it), `.msh`, `.mesh`. Throws fissure::Error.
CageFile read_cage(const std::filesystem::path& path);

/// A path's extension in lower case, with its dot (".node"): how a cage's format is told.
std::string lowercase_extension(const std::filesystem::path& path);

/// The files a cage is read from: a TetGen `.node` or `.ele` names both halves of the
/// pair (.node first); any other format, the file itself.
std::vector<std::filesystem::path> cage_files(const std::filesystem::path& path);

CageFile read_tetgen(const std::filesystem::path& node_path, const std::filesystem::path& ele_path);
CageFile read_gmsh(const std::filesystem::path& path);
CageFile read_medit(const std::filesystem::path& path);

/// Writes TetGen .node/.ele (0-based); used by tests and tools that generate cages.
void write_tetgen(const TetMesh& mesh, const std::filesystem::path& node_path, const std::filesystem::path& ele_path);

}  // namespace fissure::formats
