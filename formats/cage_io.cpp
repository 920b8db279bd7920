#include "formats/cage_io.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <unordered_map>
#include <vector>

#include "common/error.h"
#include "common/log.h"
#include "formats/text_tokens.h"

namespace fissure::formats {

std::string lowercase_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

namespace {

void finish(CageFile& cage, const CageSource& source) {
  cage.flipped_tets = validate_and_orient(cage.mesh, source);
  if (cage.flipped_tets > 0) {
    log_warning(source.tets + ": re-oriented " + std::to_string(cage.flipped_tets) + " of " +
                std::to_string(cage.mesh.tet_count()) + " tets to positive volume");
  }
}

/// Node numbers as written in a file (arbitrary tags) → dense 0-based indices.
class NodeTagMap {
 public:
  void add(std::int64_t tag, Index dense, const TextTokens& tokens) {
    if (!m_map.emplace(tag, dense).second) {
      throw Error(tokens.where() + ": node " + std::to_string(tag) + " is defined twice");
    }
  }
  Index at(std::int64_t tag, const TextTokens& tokens, const std::string& element) const {
    const auto it = m_map.find(tag);
    if (it == m_map.end()) {
      throw Error(tokens.where() + ": " + element + " references node " + std::to_string(tag) +
                      ", which is not defined in the file",
                  "the file is inconsistent or truncated; re-export it");
    }
    return it->second;
  }

 private:
  std::unordered_map<std::int64_t, Index> m_map;
};

void store_tets(TetMesh& mesh, const std::vector<Index>& corners) {
  mesh.tets.resize(4, static_cast<Eigen::Index>(corners.size() / 4));
  std::copy(corners.begin(), corners.end(), mesh.tets.data());
}

void store_nodes(TetMesh& mesh, const std::vector<double>& xyz) {
  mesh.rest_positions.resize(3, static_cast<Eigen::Index>(xyz.size() / 3));
  std::copy(xyz.begin(), xyz.end(), mesh.rest_positions.data());
}

// --- Gmsh -----------------------------------------------------------------------

void skip_section(TextTokens& tokens, std::string_view name) {
  const std::string end = "$End" + std::string(name.substr(1));
  while (tokens.next("the end of section " + std::string(name)) != end) {
  }
}

/// Corner count of the Gmsh element types that are tetrahedra (4-node, 10-node).
bool is_gmsh_tet(std::int64_t type) { return type == 4 || type == 11; }

void read_gmsh_nodes_22(TextTokens& tokens, std::vector<double>& xyz, NodeTagMap& tags) {
  const std::size_t count = tokens.next_record_count("the node count", 4);
  xyz.reserve(3 * count);
  for (std::size_t i = 0; i < count; ++i) {
    tags.add(tokens.next_integer("a node tag"), static_cast<Index>(i), tokens);
    for (int k = 0; k < 3; ++k) xyz.push_back(tokens.next_double("a node coordinate"));
  }
}

void read_gmsh_elements_22(TextTokens& tokens, const NodeTagMap& tags, std::vector<Index>& corners) {
  const std::size_t count = tokens.next_record_count("the element count", 4);
  for (std::size_t i = 0; i < count; ++i) {
    const std::int64_t tag = tokens.next_integer("an element tag");
    const std::int64_t type = tokens.next_integer("an element type");
    const std::size_t tag_count = tokens.next_count("the element's tag count");
    for (std::size_t k = 0; k < tag_count; ++k) tokens.next_integer("an element tag value");
    if (is_gmsh_tet(type)) {
      const std::string element = "element " + std::to_string(tag);
      for (int k = 0; k < 4; ++k) corners.push_back(tags.at(tokens.next_integer("a tet node"), tokens, element));
    }
    tokens.skip_rest_of_line();
  }
}

void read_gmsh_nodes_41(TextTokens& tokens, std::vector<double>& xyz, NodeTagMap& tags) {
  const std::size_t blocks = tokens.next_record_count("the node block count", 4);
  const std::size_t total = tokens.next_record_count("the node count", 4);
  tokens.next_integer("the minimum node tag");
  tokens.next_integer("the maximum node tag");
  xyz.reserve(3 * total);
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::int64_t entity_dim = tokens.next_integer("a node block's entity dimension");
    tokens.next_integer("a node block's entity tag");
    const std::int64_t parametric = tokens.next_integer("a node block's parametric flag");
    const std::size_t count = tokens.next_record_count("a node block's node count", 4);
    const auto first = static_cast<Index>(xyz.size() / 3);
    for (std::size_t i = 0; i < count; ++i) {
      tags.add(tokens.next_integer("a node tag"), first + static_cast<Index>(i), tokens);
    }
    for (std::size_t i = 0; i < count; ++i) {
      for (int k = 0; k < 3; ++k) xyz.push_back(tokens.next_double("a node coordinate"));
      if (parametric != 0) {
        for (std::int64_t k = 0; k < entity_dim; ++k) tokens.next_double("a parametric coordinate");
      }
    }
  }
  if (xyz.size() / 3 != total) {
    throw Error(tokens.where() + ": $Nodes announced " + std::to_string(total) + " nodes but its blocks hold " +
                std::to_string(xyz.size() / 3));
  }
}

void read_gmsh_elements_41(TextTokens& tokens, const NodeTagMap& tags, std::vector<Index>& corners) {
  const std::size_t blocks = tokens.next_record_count("the element block count", 4);
  tokens.next_count("the element count");
  tokens.next_integer("the minimum element tag");
  tokens.next_integer("the maximum element tag");
  for (std::size_t b = 0; b < blocks; ++b) {
    tokens.next_integer("an element block's entity dimension");
    tokens.next_integer("an element block's entity tag");
    const std::int64_t type = tokens.next_integer("an element block's element type");
    const std::size_t count = tokens.next_record_count("an element block's element count", 2);
    for (std::size_t i = 0; i < count; ++i) {
      const std::int64_t tag = tokens.next_integer("an element tag");
      if (is_gmsh_tet(type)) {
        const std::string element = "element " + std::to_string(tag);
        for (int k = 0; k < 4; ++k) corners.push_back(tags.at(tokens.next_integer("a tet node"), tokens, element));
      }
      tokens.skip_rest_of_line();
    }
  }
}

}  // namespace

CageFile read_tetgen(const std::filesystem::path& node_path, const std::filesystem::path& ele_path) {
  CageFile cage;
  cage.format = "tetgen";
  cage.node_path = node_path;
  cage.element_path = ele_path;

  TextTokens nodes(node_path);
  const std::size_t node_count = nodes.next_count("the node count");
  const std::int64_t dimension = nodes.next_integer("the dimension");
  if (dimension != 3) {
    throw Error(nodes.where() + ": the dimension is " + std::to_string(dimension) + "; a cage must be 3D");
  }
  const std::size_t attributes = nodes.next_count("the attribute count");
  const std::size_t markers = nodes.next_count("the boundary marker count");
  if (markers > 1) throw Error(nodes.where() + ": the boundary marker count must be 0 or 1");
  if (node_count > nodes.remaining() / (4 + attributes + markers)) {
    throw Error(nodes.where() + ": the header announces " + std::to_string(node_count) + " nodes but the file holds at most " +
                    std::to_string(nodes.remaining() / (4 + attributes + markers)),
                "the file is truncated or its header is wrong; re-export it");
  }
  std::vector<double> xyz;
  xyz.reserve(3 * node_count);
  std::int64_t base = 0;
  for (std::size_t i = 0; i < node_count; ++i) {
    const std::int64_t index = nodes.next_integer("a node number");
    if (i == 0) {
      if (index != 0 && index != 1) {
        throw Error(nodes.where() + ": the first node is numbered " + std::to_string(index) + "; TetGen numbers from 0 or 1");
      }
      base = index;
    } else if (index != base + static_cast<std::int64_t>(i)) {
      throw Error(nodes.where() + ": node numbered " + std::to_string(index) +
                  " where " + std::to_string(base + static_cast<std::int64_t>(i)) + " was expected (nodes must be consecutive)");
    }
    for (int k = 0; k < 3; ++k) xyz.push_back(nodes.next_double("a node coordinate"));
    for (std::size_t k = 0; k < attributes + markers; ++k) nodes.next_double("a node attribute or marker");
  }
  store_nodes(cage.mesh, xyz);

  TextTokens elements(ele_path);
  const std::size_t tet_count = elements.next_count("the tet count");
  const std::int64_t per_tet = elements.next_integer("the nodes per tet");
  if (per_tet != 4 && per_tet != 10) {
    throw Error(elements.where() + ": " + std::to_string(per_tet) + " nodes per tet; TetGen writes 4 or 10");
  }
  const std::size_t tet_attributes = elements.next_count("the attribute count");
  const std::size_t per_record = 1 + static_cast<std::size_t>(per_tet) + tet_attributes;
  if (tet_count > elements.remaining() / per_record) {
    throw Error(elements.where() + ": the header announces " + std::to_string(tet_count) +
                    " tets but the file holds at most " + std::to_string(elements.remaining() / per_record),
                "the file is truncated or its header is wrong; re-export it");
  }
  std::vector<Index> corners;
  corners.reserve(4 * tet_count);
  std::int64_t first_tet_number = 0;
  for (std::size_t t = 0; t < tet_count; ++t) {
    const std::int64_t number = elements.next_integer("a tet number");
    if (t == 0) first_tet_number = number;
    for (std::int64_t k = 0; k < per_tet; ++k) {
      const std::int64_t node = elements.next_integer("a tet node") - base;
      if (k >= 4) continue;
      if (node < 0 || node >= static_cast<std::int64_t>(node_count)) {
        throw Error(elements.where() + ": tet " + std::to_string(number) +
                        " references node " + std::to_string(node + base) + " but " + node_path.filename().string() +
                        " numbers its " + std::to_string(node_count) + " nodes from " + std::to_string(base),
                    "check that the .node and .ele files belong together");
      }
      corners.push_back(static_cast<Index>(node));
    }
    for (std::size_t k = 0; k < tet_attributes; ++k) elements.next_double("a tet attribute");
  }
  store_tets(cage.mesh, corners);
  finish(cage, CageSource{ele_path.string(), node_path.string(), static_cast<std::size_t>(std::max<std::int64_t>(first_tet_number, 0)),
                          static_cast<std::size_t>(base)});
  return cage;
}

CageFile read_gmsh(const std::filesystem::path& path) {
  CageFile cage;
  cage.node_path = cage.element_path = path;
  TextTokens tokens(path);
  if (tokens.next("$MeshFormat") != "$MeshFormat") {
    throw Error(path.string() + ":1: not a Gmsh file (expected $MeshFormat)");
  }
  const std::string version(tokens.next("the format version"));
  const std::int64_t file_type = tokens.next_integer("the file type");
  tokens.next_integer("the data size");
  if (file_type != 0) {
    throw Error(path.string() + ": binary .msh files are not supported", "re-export as ASCII (gmsh: -bin 0)");
  }
  const bool v22 = version.rfind("2.2", 0) == 0;
  const bool v41 = version.rfind("4.1", 0) == 0;
  if (!v22 && !v41) {
    throw Error(path.string() + ": Gmsh format version " + version + " is not supported",
                "re-export as version 2.2 or 4.1 ASCII (gmsh: -format msh22 or msh41)");
  }
  cage.format = v22 ? "gmsh-2.2" : "gmsh-4.1";
  skip_section(tokens, "$MeshFormat");

  std::vector<double> xyz;
  std::vector<Index> corners;
  NodeTagMap tags;
  bool have_nodes = false;
  while (!tokens.at_end()) {
    const std::string section(tokens.next("a section name"));
    if (section == "$Nodes") {
      v22 ? read_gmsh_nodes_22(tokens, xyz, tags) : read_gmsh_nodes_41(tokens, xyz, tags);
      have_nodes = true;
      skip_section(tokens, section);
    } else if (section == "$Elements") {
      if (!have_nodes) throw Error(tokens.where() + ": $Elements comes before $Nodes");
      v22 ? read_gmsh_elements_22(tokens, tags, corners) : read_gmsh_elements_41(tokens, tags, corners);
      skip_section(tokens, section);
    } else if (!section.empty() && section[0] == '$') {
      skip_section(tokens, section);
    } else {
      throw Error(tokens.where() + ": expected a $Section, found " + quote_from_file(section));
    }
  }
  if (!have_nodes) throw Error(path.string() + ": no $Nodes section");
  if (corners.empty()) {
    throw Error(path.string() + ": no tetrahedra (element type 4 or 11) in the file",
                "mesh the volume (gmsh -3), not only its surface");
  }
  store_nodes(cage.mesh, xyz);
  store_tets(cage.mesh, corners);
  finish(cage, CageSource{path.string(), path.string(), 0, 0});
  return cage;
}

CageFile read_medit(const std::filesystem::path& path) {
  CageFile cage;
  cage.format = "medit";
  cage.node_path = cage.element_path = path;
  TextTokens tokens(path);
  // Entries per record of the keywords we skip (values after the count).
  static const std::unordered_map<std::string, int> kSkippedArity{
      {"Edges", 3},       {"Triangles", 4},        {"Quadrilaterals", 5},   {"Hexahedra", 9},
      {"Prisms", 7},      {"Pyramids", 6},         {"Corners", 1},          {"RequiredVertices", 1},
      {"Ridges", 1},      {"RequiredEdges", 1},    {"RequiredTriangles", 1}, {"Normals", 3},
      {"Tangents", 3},    {"NormalAtVertices", 2}, {"TangentAtVertices", 2}, {"Identifier", 0}};
  std::vector<double> xyz;
  std::vector<Index> corners;
  bool have_vertices = false;
  bool ended = false;
  while (!tokens.at_end() && !ended) {
    const std::string keyword(tokens.next("a keyword"));
    if (keyword == "MeshVersionFormatted") {
      tokens.next_integer("the format version");
    } else if (keyword == "Dimension") {
      const std::int64_t dimension = tokens.next_integer("the dimension");
      if (dimension != 3) throw Error(tokens.where() + ": Dimension " + std::to_string(dimension) + "; a cage must be 3D");
    } else if (keyword == "Vertices") {
      const std::size_t count = tokens.next_record_count("the vertex count", 4);
      xyz.reserve(3 * count);
      for (std::size_t i = 0; i < count; ++i) {
        for (int k = 0; k < 3; ++k) xyz.push_back(tokens.next_double("a vertex coordinate"));
        tokens.next_integer("a vertex reference");
      }
      have_vertices = true;
    } else if (keyword == "Tetrahedra") {
      if (!have_vertices) throw Error(tokens.where() + ": Tetrahedra comes before Vertices");
      const std::size_t count = tokens.next_record_count("the tet count", 5);
      const std::size_t vertex_count = xyz.size() / 3;
      for (std::size_t t = 0; t < count; ++t) {
        for (int k = 0; k < 4; ++k) {
          const std::int64_t vertex = tokens.next_integer("a tet vertex");
          if (vertex < 1 || vertex > static_cast<std::int64_t>(vertex_count)) {
            throw Error(tokens.where() + ": tet " + std::to_string(t + 1) + " references vertex " +
                            std::to_string(vertex) + " but the file has " + std::to_string(vertex_count) +
                            " (numbered from 1)");
          }
          corners.push_back(static_cast<Index>(vertex - 1));
        }
        tokens.next_integer("a tet reference");
      }
    } else if (keyword == "End") {
      ended = true;
    } else if (const auto it = kSkippedArity.find(keyword); it != kSkippedArity.end()) {
      if (it->second == 0) {
        tokens.next("the identifier");
        continue;
      }
      const std::size_t count =
          tokens.next_record_count("the " + keyword + " count", static_cast<std::size_t>(it->second));
      for (std::size_t i = 0; i < count * static_cast<std::size_t>(it->second); ++i) tokens.next("a " + keyword + " value");
    } else {
      throw Error(tokens.where() + ": unknown MEDIT keyword " + quote_from_file(keyword),
                  "supported: Vertices, Tetrahedra and the common surface keywords (skipped)");
    }
  }
  if (!have_vertices) throw Error(path.string() + ": no Vertices section");
  if (corners.empty()) throw Error(path.string() + ": no Tetrahedra section", "the file holds no volume mesh");
  store_nodes(cage.mesh, xyz);
  store_tets(cage.mesh, corners);
  finish(cage, CageSource{path.string(), path.string(), 1, 1});
  return cage;
}

std::vector<std::filesystem::path> cage_files(const std::filesystem::path& path) {
  const std::string ext = lowercase_extension(path);
  if (ext != ".node" && ext != ".ele") return {path};
  return {std::filesystem::path(path).replace_extension(".node"), std::filesystem::path(path).replace_extension(".ele")};
}

CageFile read_cage(const std::filesystem::path& path) {
  const std::string ext = lowercase_extension(path);
  if (ext == ".node" || ext == ".ele") {
    const auto files = cage_files(path);
    return read_tetgen(files[0], files[1]);
  }
  if (ext == ".msh") return read_gmsh(path);
  if (ext == ".mesh") return read_medit(path);
  throw Error(path.string() + ": unknown cage format '" + ext + "'",
              "supported: .node/.ele (TetGen), .msh (Gmsh 2.2/4.1 ASCII), .mesh (MEDIT)");
}

void write_tetgen(const TetMesh& mesh, const std::filesystem::path& node_path, const std::filesystem::path& ele_path) {
  std::ofstream node(node_path);
  node.precision(17);
  node << mesh.node_count() << " 3 0 0\n";
  for (Eigen::Index i = 0; i < mesh.rest_positions.cols(); ++i) {
    node << i << ' ' << mesh.rest_positions(0, i) << ' ' << mesh.rest_positions(1, i) << ' '
         << mesh.rest_positions(2, i) << '\n';
  }
  std::ofstream ele(ele_path);
  ele << mesh.tet_count() << " 4 0\n";
  for (Eigen::Index t = 0; t < mesh.tets.cols(); ++t) {
    ele << t << ' ' << mesh.tets(0, t) << ' ' << mesh.tets(1, t) << ' ' << mesh.tets(2, t) << ' ' << mesh.tets(3, t)
        << '\n';
  }
  if (!node || !ele) throw Error(node_path.string() + ": could not write the cage");
}

}  // namespace fissure::formats
