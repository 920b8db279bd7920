#pragma once
/// Writing tetrahedral cages in the formats read_cage reads: TetGen .node/.ele
/// (0-based), Gmsh .msh 2.2 ASCII and MEDIT .mesh. Coordinates are written with 17
/// significant digits, so reading a written cage gives back the same doubles; the same
/// cage always gives the same bytes.

#include <filesystem>
#include <string>

#include "common/tet_mesh.h"

namespace fissure::formats {

std::string tetgen_node_text(const TetMesh& mesh);
std::string tetgen_ele_text(const TetMesh& mesh);
std::string gmsh_text(const TetMesh& mesh);
std::string medit_text(const TetMesh& mesh);

/// Writes `mesh` to `path`, the format chosen by the extension as read_cage chooses it
/// (`.node` or `.ele`: both files of the pair). Each file is written atomically; a
/// failure leaves neither file of a pair behind. Throws fissure::Error naming the path.
void write_cage(const TetMesh& mesh, const std::filesystem::path& path);

/// Whether `path`'s extension names a cage format (.node, .ele, .msh, .mesh).
bool is_cage_path(const std::filesystem::path& path);

}  // namespace fissure::formats
