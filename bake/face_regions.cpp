#include "bake/face_regions.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "bake/exact_predicates.h"

namespace fissure::bake {
namespace {

struct EdgeCrossing {
  double t;     ///< position along the edge, 0 at its first node
  bool after;   ///< the solid is on the edge's far side of this point (toward t = 1)
};

using Piece = Eigen::Matrix<double, 3, 2>;

/// A face's three corners and its (unnormalised) normal.
struct FaceFrame {
  Vec3 corner[3];
  Vec3 normal;
};

Piece make_piece(const Vec3& from, const Vec3& to) {
  Piece piece;
  piece << from, to;
  return piece;
}

/// A segment can run along one of the face's edges (the surface crosses the face's
/// plane exactly there). It bounds this face's region only if the solid is on the
/// face's side of it (its direction agrees with the edge's); either way it replaces the
/// edge over its span, and its ends are no crossings. Adds the segments that bound the
/// region to `pieces`; returns, per segment of the face, the edge it runs along or -1.
std::vector<int> add_contour_pieces(const formats::Embedding& e, FaceIndex f, const FaceFrame& face,
                                    std::vector<Piece>& pieces) {
  const std::uint64_t first = e.contour_offsets[f], last = e.contour_offsets[f + 1];
  std::vector<int> along(last - first, -1);
  for (std::uint64_t s = first; s < last; ++s) {
    for (int k = 0; k < 3; ++k) {
      auto on_edge_k = [&](std::uint8_t feature) { return feature == k || feature == 3 + k || feature == 3 + (k + 1) % 3; };
      if (on_edge_k(e.contour_feature[s][0]) && on_edge_k(e.contour_feature[s][1])) along[s - first] = k;
    }
    const int k = along[s - first];
    const Vec3 edge = face.corner[(k < 0 ? 0 : k + 1) % 3] - face.corner[k < 0 ? 0 : k];
    if (k < 0 || (e.contour_points[s].col(1) - e.contour_points[s].col(0)).dot(edge) > 0.0) {
      pieces.push_back(e.contour_points[s]);
    }
  }
  return along;
}

/// Where the contour ends on edge k (node k → k+1) and which way each toggles; and the
/// spans of the edge that along-edge segments replace. Which way, the segment's
/// orientation says (inside on its left): the edge beyond the point is inside iff
/// d × e · n > 0.
void edge_crossings(const formats::Embedding& e, FaceIndex f, int k, const FaceFrame& face, const std::vector<int>& along,
                    std::vector<EdgeCrossing>& crossings, std::vector<std::pair<double, double>>& covered) {
  const Vec3 a = face.corner[k], edge = face.corner[(k + 1) % 3] - a;
  const std::uint64_t first = e.contour_offsets[f], last = e.contour_offsets[f + 1];
  for (std::uint64_t s = first; s < last; ++s) {
    if (along[s - first] == k) {
      double t0 = (e.contour_points[s].col(0) - a).dot(edge) / edge.squaredNorm();
      double t1 = (e.contour_points[s].col(1) - a).dot(edge) / edge.squaredNorm();
      covered.emplace_back(std::min(t0, t1), std::max(t0, t1));
    }
    if (along[s - first] >= 0) continue;
    const Vec3 direction = e.contour_points[s].col(1) - e.contour_points[s].col(0);
    for (int end = 0; end < 2; ++end) {
      const std::uint8_t feature = e.contour_feature[s][static_cast<std::size_t>(end)];
      const bool on_edge = feature == k || feature == 3 + k || feature == 3 + (k + 1) % 3;
      if (!on_edge) continue;
      const double t = feature == 3 + k ? 0.0
                       : feature == 3 + (k + 1) % 3
                           ? 1.0
                           : std::clamp((e.contour_points[s].col(end) - a).dot(edge) / edge.squaredNorm(), 0.0, 1.0);
      crossings.push_back({t, direction.cross(edge).dot(face.normal) > 0.0});
    }
  }
  std::sort(crossings.begin(), crossings.end(), [](const EdgeCrossing& x, const EdgeCrossing& y) { return x.t < y.t; });
  std::sort(covered.begin(), covered.end());
}

/// Adds edge k's inside spans, minus the spans along-edge segments replace, to `pieces`.
/// `state`: inside at the edge's first node.
void add_edge_spans(const FaceFrame& face, int k, bool state, const std::vector<EdgeCrossing>& crossings,
                    const std::vector<std::pair<double, double>>& covered, std::vector<Piece>& pieces) {
  const Vec3 a = face.corner[k], edge = face.corner[(k + 1) % 3] - a;
  std::vector<std::pair<double, double>> spans;
  double from = 0.0;
  for (const EdgeCrossing& c : crossings) {
    if (state && c.t > from) spans.emplace_back(from, c.t);
    state = !state;
    from = c.t;
  }
  if (state && from < 1.0) spans.emplace_back(from, 1.0);
  for (auto [lo, hi] : spans) {
    for (const auto& [c0, c1] : covered) {
      if (c1 <= lo || c0 >= hi) continue;
      if (c0 > lo) pieces.push_back(make_piece(a + lo * edge, a + c0 * edge));
      lo = std::max(lo, c1);
    }
    if (hi > lo) pieces.push_back(make_piece(a + lo * edge, a + hi * edge));
  }
}

/// A crossing face's region: its contour segments, closed along its edges. Returns
/// whether the contours agree with the node classes on every edge.
bool crossing_face_pieces(const formats::Bundle& b, FaceIndex f, const FaceFrame& face, std::vector<Piece>& pieces) {
  const formats::Embedding& e = b.embedding;
  const std::vector<int> along = add_contour_pieces(e, f, face, pieces);
  bool consistent = true;
  for (int k = 0; k < 3; ++k) {
    std::vector<EdgeCrossing> crossings;
    std::vector<std::pair<double, double>> covered;
    edge_crossings(e, f, k, face, along, crossings, covered);
    // State at the edge's first node: from the first crossing when it is alone at
    // its position (exact geometry), else from the node's class.
    bool state = e.node_inside[b.faces.nodes(k, f)] != 0;
    if (!crossings.empty() && (crossings.size() == 1 || crossings[1].t > crossings[0].t)) {
      const bool from_contour = !crossings[0].after;
      if (crossings[0].t > 0.0 && from_contour != state) consistent = false;
      state = from_contour;
    }
    add_edge_spans(face, k, state, crossings, covered, pieces);
  }
  return consistent;
}

}  // namespace

FaceRegions build_face_regions(const formats::Bundle& b) {
  const auto& e = b.embedding;
  const auto& nodes = b.cage.rest_positions;
  FaceRegions regions;
  const std::size_t face_count = b.faces.face_count();
  regions.face_class.resize(face_count);
  regions.inside_area.resize(face_count);
  regions.offsets.assign(face_count + 1, 0);
  for (FaceIndex f = 0; f < face_count; ++f) {
    FaceFrame face{{nodes.col(b.faces.nodes(0, f)), nodes.col(b.faces.nodes(1, f)), nodes.col(b.faces.nodes(2, f))}, {}};
    face.normal = (face.corner[1] - face.corner[0]).cross(face.corner[2] - face.corner[0]);
    const Vec3 unit = face.normal.normalized();
    int inside_nodes = 0;
    for (int k = 0; k < 3; ++k) inside_nodes += e.node_inside[b.faces.nodes(k, f)];

    std::vector<Piece> pieces;
    if (e.face_degenerate[f]) {
      // The surface lies in this face's plane: which side of it is solid, and so the
      // face's inside region, is not defined by the contours. No region, no tile; the
      // tets beside it get their mass from sampling (collision_proxies.cpp).
      regions.face_class[f] = FaceClass::Degenerate;
    } else if (e.contour_offsets[f] == e.contour_offsets[f + 1]) {
      // No surface crosses the face: it is wholly inside or outside. The nodes agree
      // unless the surface is open or the winding numbers are borderline: majority.
      regions.face_class[f] = inside_nodes >= 2 ? FaceClass::Inside : FaceClass::Outside;
      if (inside_nodes == 1 || inside_nodes == 2) ++regions.inconsistent_faces;
      if (regions.face_class[f] == FaceClass::Inside) {
        for (int k = 0; k < 3; ++k) pieces.push_back(make_piece(face.corner[k], face.corner[(k + 1) % 3]));
      }
    } else {
      regions.face_class[f] = FaceClass::Crossing;
      if (!crossing_face_pieces(b, f, face, pieces)) ++regions.inconsistent_faces;
    }
    double twice_area = 0.0;
    for (const auto& piece : pieces) twice_area += (piece.col(0) - face.corner[0]).cross(piece.col(1) - face.corner[0]).dot(unit);
    regions.inside_area[f] = std::clamp(0.5 * twice_area, 0.0, 0.5 * face.normal.norm());
    regions.pieces.insert(regions.pieces.end(), pieces.begin(), pieces.end());
    regions.offsets[f + 1] = regions.pieces.size();
  }
  return regions;
}

int region_winding(const FaceRegions& regions, FaceIndex face, const Vec3& face_normal, const Vec3& x) {
  // Project by dropping the normal's dominant axis: exact (it only selects
  // coordinates); if that mirrors the plane, every orientation flips alike.
  int axis = 0;
  face_normal.cwiseAbs().maxCoeff(&axis);
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  const double px = x[u], py = x[v];
  int winding = 0;
  for (std::uint64_t i = regions.offsets[face]; i < regions.offsets[face + 1]; ++i) {
    const auto& piece = regions.pieces[i];
    const double ax = piece(u, 0), ay = piece(v, 0), bx = piece(u, 1), by = piece(v, 1);
    // Sunday's crossing rule with exact orientation signs: upward edges that pass the
    // point on their left count +1, downward edges with the point on their right −1.
    if (ay <= py) {
      if (by > py && orientation_2d(ax, ay, bx, by, px, py) > 0) ++winding;
    } else if (by <= py && orientation_2d(ax, ay, bx, by, px, py) < 0) {
      --winding;
    }
  }
  return winding;
}

}  // namespace fissure::bake
