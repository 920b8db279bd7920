#include "bake/cage_quality.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <vector>

#include "bake/cage_topology.h"
#include "bake/surface_distance.h"
#include "common/json_writer.h"
#include "common/union_find.h"

namespace fissure::bake {
namespace {

constexpr double kDegrees = 180.0 / 3.14159265358979323846;

/// The cage's boundary faces as a surface, for distances to its hull.
SurfaceMesh boundary_surface(const TetMesh& cage, const CageFaces& faces) {
  SurfaceMesh hull;
  hull.positions = cage.rest_positions;
  std::vector<Index> corners;
  for (FaceIndex f = 0; f < faces.face_count(); ++f) {
    if (!faces.is_boundary(f)) continue;
    for (int k = 0; k < 3; ++k) corners.push_back(faces.nodes(k, f));
  }
  hull.triangles = Eigen::Map<const Matrix3Xu>(corners.data(), 3, static_cast<Eigen::Index>(corners.size() / 3));
  return hull;
}

std::size_t face_connected_pieces(const TetMesh& cage, const CageFaces& faces) {
  std::vector<Index> parent(cage.tet_count());
  std::iota(parent.begin(), parent.end(), Index{0});
  for (FaceIndex f = 0; f < faces.face_count(); ++f) {
    if (!faces.is_boundary(f)) parent[find_root(parent, faces.tets(0, f))] = find_root(parent, faces.tets(1, f));
  }
  std::size_t pieces = 0;
  for (Index t = 0; t < parent.size(); ++t) pieces += find_root(parent, t) == t;
  return pieces;
}

double enclosed_volume(const SurfaceMesh& mesh) {
  double volume = 0;
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3 a = mesh.positions.col(mesh.triangles(0, t)), b = mesh.positions.col(mesh.triangles(1, t)),
               c = mesh.positions.col(mesh.triangles(2, t));
    volume += a.dot(b.cross(c)) / 6.0;
  }
  return std::abs(volume);
}

/// Dihedral angles, edge lengths and volumes of every tet.
void measure_tets(const TetMesh& cage, CageQuality& q) {
  q.min_dihedral_deg = cage.tet_count() ? 180.0 : 0.0;
  double edges = 0;
  for (TetIndex t = 0; t < cage.tet_count(); ++t) {
    Vec3 p[4];
    for (int k = 0; k < 4; ++k) p[k] = cage.rest_positions.col(cage.tets(k, t));
    double longest = 0;
    for (int i = 0; i < 4; ++i) {
      for (int j = i + 1; j < 4; ++j) {
        edges += (p[i] - p[j]).norm();
        longest = std::max(longest, (p[i] - p[j]).norm());
      }
    }
    const double volume = signed_volume(p[0], p[1], p[2], p[3]);
    q.cage_volume += volume;
    if (!(volume > kDegenerateRelativeVolume * longest * longest * longest)) ++q.degenerate_tets;
    for (const double angle : dihedral_angles_deg(p[0], p[1], p[2], p[3])) {
      q.min_dihedral_deg = std::min(q.min_dihedral_deg, angle);
      q.max_dihedral_deg = std::max(q.max_dihedral_deg, angle);
      // A micro-degree up, so the lattice's exact 60° and 90° do not split between bins by rounding.
      ++q.dihedral_histogram[std::min<std::size_t>(17, static_cast<std::size_t>(std::max(0.0, angle + 1e-6) / 10.0))];
    }
  }
  q.mean_edge = cage.tet_count() ? edges / (6.0 * static_cast<double>(cage.tet_count())) : 0.0;
}

}  // namespace

std::array<double, 6> dihedral_angles_deg(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  const Vec3 p[4] = {p0, p1, p2, p3};
  // Outward-or-inward normal of the face opposite each node, all the same way round:
  // the angle at edge (i, j) is π minus the angle between the normals of the faces
  // opposite the other two nodes.
  Vec3 normal[4];
  for (int i = 0; i < 4; ++i) {
    const Vec3& a = p[(i + 1) % 4];
    const Vec3& b = p[(i + 2) % 4];
    const Vec3& c = p[(i + 3) % 4];
    Vec3 n = (b - a).cross(c - a);
    if (n.dot(p[i] - a) > 0) n = -n;  // point away from the opposite node
    normal[i] = n.normalized();
  }
  std::array<double, 6> angles{};
  int e = 0;
  for (int i = 0; i < 4; ++i) {
    for (int j = i + 1; j < 4; ++j) {
      int k = 0;
      while (k == i || k == j) ++k;
      int l = 6 - i - j - k;
      angles[static_cast<std::size_t>(e++)] = 180.0 - std::acos(std::clamp(normal[k].dot(normal[l]), -1.0, 1.0)) * kDegrees;
    }
  }
  return angles;
}

CageQuality measure_cage(const SurfaceMesh& mesh, const TetMesh& cage) {
  CageQuality q;
  q.nodes = cage.node_count();
  q.tets = cage.tet_count();
  measure_tets(cage, q);
  q.solid_volume = enclosed_volume(mesh);
  const CageFaces faces = build_cage_faces(cage, "the cage");
  q.pieces = face_connected_pieces(cage, faces);
  q.holes = cage_holes(cage, faces);
  if (const auto holes = surface_holes(mesh)) q.surface_holes = static_cast<std::ptrdiff_t>(*holes);
  const SurfaceMesh hull = boundary_surface(cage, faces);
  const SurfaceDistance to_hull(hull), to_surface(mesh);
  q.clearance_min = std::numeric_limits<double>::infinity();
  for (Eigen::Index i = 0; i < mesh.triangles.size(); ++i) {
    q.clearance_min = std::min(q.clearance_min, to_hull.distance(mesh.positions.col(mesh.triangles.data()[i])));
  }
  std::vector<std::uint8_t> on_hull(cage.node_count(), 0);
  for (Eigen::Index i = 0; i < hull.triangles.size(); ++i) on_hull[hull.triangles.data()[i]] = 1;
  for (Index n = 0; n < cage.node_count(); ++n) {
    if (on_hull[n]) q.overhang_max = std::max(q.overhang_max, to_surface.distance(cage.rest_positions.col(n)));
  }
  if (!std::isfinite(q.clearance_min)) q.clearance_min = 0;
  return q;
}

std::string quality_text(const CageQuality& q) {
  char buffer[512];
  std::string text;
  std::snprintf(buffer, sizeof buffer, "size: %zu tets, %zu nodes, %zu face-connected piece%s, mean edge %.4g\n", q.tets,
                q.nodes, q.pieces, q.pieces == 1 ? "" : "s", q.mean_edge);
  text += buffer;
  std::snprintf(buffer, sizeof buffer, "quality: dihedral angles %.1f° … %.1f°, %zu degenerate tets; histogram:", q.min_dihedral_deg,
                q.max_dihedral_deg, q.degenerate_tets);
  text += buffer;
  for (std::size_t b = 0; b < q.dihedral_histogram.size(); ++b) {
    if (q.dihedral_histogram[b] == 0) continue;
    std::snprintf(buffer, sizeof buffer, " %zu–%zu°: %zu", 10 * b, 10 * b + 10, q.dihedral_histogram[b]);
    text += buffer;
  }
  std::snprintf(buffer, sizeof buffer,
                "\nvolume: cage %.4g, solid %.4g (×%.2f)\nclearance: surface to the cage's hull ≥ %.4g (%.2f edges); "
                "hull to the surface ≤ %.4g (%.2f edges)\n",
                q.cage_volume, q.solid_volume, q.solid_volume > 0 ? q.cage_volume / q.solid_volume : 0.0, q.clearance_min,
                q.mean_edge > 0 ? q.clearance_min / q.mean_edge : 0.0, q.overhang_max,
                q.mean_edge > 0 ? q.overhang_max / q.mean_edge : 0.0);
  text += buffer;
  if (q.surface_holes >= 0) {
    std::snprintf(buffer, sizeof buffer, "holes: %zu through the cage, %td through the surface's solid\n", q.holes,
                  q.surface_holes);
  } else {
    std::snprintf(buffer, sizeof buffer, "holes: %zu through the cage (the surface is open)\n", q.holes);
  }
  return text + buffer;
}

std::string quality_json(const CageQuality& q) {
  JsonWriter j;
  j.begin_object();
  j.key("tets").value(static_cast<std::uint64_t>(q.tets)).key("nodes").value(static_cast<std::uint64_t>(q.nodes));
  j.key("pieces").value(static_cast<std::uint64_t>(q.pieces));
  j.key("min_dihedral_deg").value(q.min_dihedral_deg).key("max_dihedral_deg").value(q.max_dihedral_deg);
  j.key("dihedral_histogram_10deg").begin_array();
  for (const std::size_t count : q.dihedral_histogram) j.value(static_cast<std::uint64_t>(count));
  j.end_array();
  j.key("degenerate_tets").value(static_cast<std::uint64_t>(q.degenerate_tets));
  j.key("mean_edge").value(q.mean_edge).key("cage_volume").value(q.cage_volume).key("solid_volume").value(q.solid_volume);
  j.key("clearance_min").value(q.clearance_min).key("overhang_max").value(q.overhang_max);
  j.key("holes").value(static_cast<std::uint64_t>(q.holes));
  if (q.surface_holes >= 0) j.key("surface_holes").value(static_cast<std::uint64_t>(q.surface_holes));
  j.end_object();
  return j.str() + "\n";
}

}  // namespace fissure::bake
