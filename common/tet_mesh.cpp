#include "common/tet_mesh.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "common/error.h"

namespace fissure {

double signed_volume(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  return (p1 - p0).dot((p2 - p0).cross(p3 - p0)) / 6.0;
}

double signed_volume(const TetMesh& mesh, TetIndex t) {
  const auto& p = mesh.rest_positions;
  return signed_volume(p.col(mesh.tets(0, t)), p.col(mesh.tets(1, t)), p.col(mesh.tets(2, t)),
                       p.col(mesh.tets(3, t)));
}

namespace {

std::string numbered(const char* what, std::size_t index, std::size_t first_number) {
  return std::string(what) + " " + std::to_string(index + first_number);
}

void check_nodes(const TetMesh& mesh, const CageSource& source) {
  for (Eigen::Index n = 0; n < mesh.rest_positions.cols(); ++n) {
    if (!mesh.rest_positions.col(n).allFinite()) {
      throw Error(source.nodes + ": " + numbered("node", static_cast<std::size_t>(n), source.first_node_number) +
                  " has a non-finite coordinate (NaN or Inf)");
    }
  }
}

void check_corners(const TetMesh& mesh, TetIndex t, const CageSource& source) {
  const std::string tet = source.tets + ": " + numbered("tet", t, source.first_tet_number);
  for (int i = 0; i < 4; ++i) {
    if (mesh.tets(i, t) >= mesh.node_count()) {
      throw Error(tet + " references " + numbered("node", mesh.tets(i, t), source.first_node_number) + " but the cage has " +
                      std::to_string(mesh.node_count()) + " nodes",
                  "check the node numbering (0- or 1-based) and that the .node and .ele files belong together");
    }
    for (int j = 0; j < i; ++j) {
      if (mesh.tets(i, t) == mesh.tets(j, t)) {
        throw Error(tet + " uses " + numbered("node", mesh.tets(i, t), source.first_node_number) + " twice");
      }
    }
  }
}

/// A flat tet is usually a misplaced node, so the message lists the four, in the node
/// file's numbering and naming that file when it is another one.
void check_volume(const TetMesh& mesh, TetIndex t, double volume, const CageSource& source) {
  const auto& p = mesh.rest_positions;
  double longest = 0.0;
  for (int i = 0; i < 4; ++i) {
    for (int j = i + 1; j < 4; ++j) longest = std::max(longest, (p.col(mesh.tets(i, t)) - p.col(mesh.tets(j, t))).norm());
  }
  if (std::abs(volume) > kDegenerateRelativeVolume * longest * longest * longest) return;
  char numbers[96];
  std::snprintf(numbers, sizeof numbers, "volume %.3g for longest edge %.3g", volume, longest);
  std::string nodes;
  for (int i = 0; i < 4; ++i) nodes += (i ? ", " : "") + std::to_string(mesh.tets(i, t) + source.first_node_number);
  const std::string where = source.nodes == source.tets ? "" : " of " + source.nodes;
  throw Error(source.tets + ": " + numbered("tet", t, source.first_tet_number) + " is degenerate (" + numbers + "): nodes " +
                  nodes + where + " are (nearly) coplanar",
              "move one of those nodes, or remove or re-mesh the flat tetrahedron");
}

}  // namespace

std::size_t validate_and_orient(TetMesh& mesh, const CageSource& source) {
  if (mesh.node_count() == 0) throw Error(source.nodes + ": the cage has no nodes");
  if (mesh.tet_count() == 0) throw Error(source.tets + ": the cage has no tetrahedra");
  if (mesh.node_count() >= kInvalidIndex || mesh.tet_count() >= kInvalidIndex) {
    throw Error(source.tets + ": the cage has more than 2^32-2 nodes or tets");
  }
  check_nodes(mesh, source);
  std::size_t flipped = 0;
  for (Index t = 0; t < mesh.tet_count(); ++t) {
    check_corners(mesh, t, source);
    const double volume = signed_volume(mesh, t);
    check_volume(mesh, t, volume, source);
    if (volume < 0.0) {
      std::swap(mesh.tets(2, t), mesh.tets(3, t));
      ++flipped;
    }
  }
  return flipped;
}

std::size_t validate_and_orient(TetMesh& mesh, const std::string& source, std::size_t first_number) {
  return validate_and_orient(mesh, CageSource{source, source, first_number, first_number});
}

double face_area(const TetMesh& mesh, const CageFaces& faces, FaceIndex f) {
  const Vec3 a = mesh.rest_positions.col(faces.nodes(0, f));
  return 0.5 * (mesh.rest_positions.col(faces.nodes(1, f)) - a).cross(mesh.rest_positions.col(faces.nodes(2, f)) - a).norm();
}

CageFaces build_cage_faces(const TetMesh& mesh, const std::string& source) {
  struct Entry {
    std::array<Index, 3> key;
    TetIndex tet;
    int local;
  };
  std::vector<Entry> entries;
  entries.reserve(mesh.tet_count() * 4);
  for (Index t = 0; t < mesh.tet_count(); ++t) {
    for (int i = 0; i < 4; ++i) {
      std::array<Index, 3> key{mesh.tets(kTetFaceNodes[i][0], t), mesh.tets(kTetFaceNodes[i][1], t),
                               mesh.tets(kTetFaceNodes[i][2], t)};
      std::sort(key.begin(), key.end());
      entries.push_back({key, t, i});
    }
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.key != b.key ? a.key < b.key : (a.tet != b.tet ? a.tet < b.tet : a.local < b.local);
  });

  CageFaces faces;
  faces.tet_faces.resize(4, static_cast<Eigen::Index>(mesh.tet_count()));
  std::vector<std::array<Index, 3>> nodes;
  std::vector<std::array<Index, 2>> owners;
  for (std::size_t i = 0; i < entries.size();) {
    std::size_t j = i;
    while (j < entries.size() && entries[j].key == entries[i].key) ++j;
    if (j - i > 2) {
      throw Error(source + ": face (" + std::to_string(entries[i].key[0]) + ", " + std::to_string(entries[i].key[1]) +
                      ", " + std::to_string(entries[i].key[2]) + ") is shared by " + std::to_string(j - i) +
                      " tets; a cage face may belong to at most two",
                  "the cage is non-manifold or has duplicated tets; re-mesh it");
    }
    const auto f = static_cast<FaceIndex>(nodes.size());
    const Entry& first = entries[i];
    if (j - i == 2) {
      // Two tets sharing a face must lie on opposite sides of it: their outward orders
      // of the face's nodes are then opposite cyclic orders.
      const Entry& second = entries[i + 1];
      const auto& fa = kTetFaceNodes[static_cast<std::size_t>(first.local)];
      const auto& fb = kTetFaceNodes[static_cast<std::size_t>(second.local)];
      const std::array<Index, 3> a{mesh.tets(fa[0], first.tet), mesh.tets(fa[1], first.tet), mesh.tets(fa[2], first.tet)};
      const std::array<Index, 3> b{mesh.tets(fb[0], second.tet), mesh.tets(fb[1], second.tet), mesh.tets(fb[2], second.tet)};
      const bool same_cycle = (a == b) || (a == std::array<Index, 3>{b[1], b[2], b[0]}) ||
                              (a == std::array<Index, 3>{b[2], b[0], b[1]});
      if (same_cycle) {
        throw Error(source + ": tets " + std::to_string(first.tet) + " and " + std::to_string(second.tet) +
                        " lie on the same side of their shared face, so they overlap",
                    "the cage is folded or has duplicated tets; re-mesh it");
      }
    }
    nodes.push_back({mesh.tets(kTetFaceNodes[first.local][0], first.tet),
                     mesh.tets(kTetFaceNodes[first.local][1], first.tet),
                     mesh.tets(kTetFaceNodes[first.local][2], first.tet)});
    owners.push_back({first.tet, j - i == 2 ? entries[i + 1].tet : kInvalidIndex});
    for (std::size_t k = i; k < j; ++k) faces.tet_faces(entries[k].local, entries[k].tet) = f;
    i = j;
  }
  faces.nodes.resize(3, static_cast<Eigen::Index>(nodes.size()));
  faces.tets.resize(2, static_cast<Eigen::Index>(nodes.size()));
  for (std::size_t f = 0; f < nodes.size(); ++f) {
    for (int k = 0; k < 3; ++k) faces.nodes(k, static_cast<Eigen::Index>(f)) = nodes[f][static_cast<std::size_t>(k)];
    for (int k = 0; k < 2; ++k) faces.tets(k, static_cast<Eigen::Index>(f)) = owners[f][static_cast<std::size_t>(k)];
  }
  return faces;
}

}  // namespace fissure
