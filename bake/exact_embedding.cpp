// One of the few translation units that include CGAL (builds are slow; keep it so).
#include "bake/exact_embedding.h"

#include "common/barycentric.h"
#include "common/log.h"

#include <CGAL/Cartesian_converter.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/intersections.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

namespace fissure::bake {
namespace {

using Epick = CGAL::Exact_predicates_inexact_constructions_kernel;
using Epeck = CGAL::Exact_predicates_exact_constructions_kernel;
using Point = Epick::Point_3;
using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, Index, CGAL::Box_intersection_d::ID_EXPLICIT>;

Point to_point(const Matrix3Xd& positions, Index i) {
  return {positions(0, i), positions(1, i), positions(2, i)};
}

template <int N>
Box make_box(const Matrix3Xd& positions, const Eigen::Matrix<Index, N, 1>& corners, Index id) {
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = hi[k] = positions(k, corners[0]);
    for (int c = 1; c < N; ++c) {
      lo[k] = std::min(lo[k], positions(k, corners[c]));
      hi[k] = std::max(hi[k], positions(k, corners[c]));
    }
  }
  return Box(lo, hi, id);
}

Epick::Triangle_3 render_triangle(const SurfaceMesh& mesh, TriangleIndex t) {
  return {to_point(mesh.positions, mesh.triangles(0, t)), to_point(mesh.positions, mesh.triangles(1, t)),
          to_point(mesh.positions, mesh.triangles(2, t))};
}

/// Exact sides of a triangle's vertices w.r.t. a tet's four face planes:
/// side[f][j] for face f (opposite node f, outward order) and vertex j. The tet's
/// inside is NEGATIVE.
struct PairSides {
  Point nodes[4];
  CGAL::Orientation side[4][3];
};

PairSides pair_sides(const Epick::Triangle_3& triangle, const TetMesh& cage, TetIndex tet) {
  PairSides p;
  for (int i = 0; i < 4; ++i) p.nodes[i] = to_point(cage.rest_positions, cage.tets(i, tet));
  for (int f = 0; f < 4; ++f) {
    const auto& local = kTetFaceNodes[static_cast<std::size_t>(f)];
    for (int j = 0; j < 3; ++j) {
      p.side[f][j] = CGAL::orientation(p.nodes[local[0]], p.nodes[local[1]], p.nodes[local[2]], triangle[j]);
    }
  }
  return p;
}

enum class PairStatus : std::uint8_t { Miss = 0, Hit = 1, Dropped = 2 };

/// Whether the closed triangle and the closed tet intersect, and whether the pair is
/// kept: a triangle lying in an interior face of the tet and facing into it belongs to
/// the neighbour behind it.
PairStatus classify_pair(const SurfaceMesh& mesh, const TetMesh& cage, const CageFaces& faces, TriangleIndex tri,
                         TetIndex tet) {
  const auto triangle = render_triangle(mesh, tri);
  const PairSides p = pair_sides(triangle, cage, tet);
  bool all_inside = true;
  for (int f = 0; f < 4; ++f) {
    const auto* s = p.side[f];
    // All three vertices strictly outside one face plane: separated (the common case
    // among box-overlap candidates, decided without CGAL's full intersection test).
    if (s[0] == CGAL::POSITIVE && s[1] == CGAL::POSITIVE && s[2] == CGAL::POSITIVE) return PairStatus::Miss;
    all_inside = all_inside && s[0] != CGAL::POSITIVE && s[1] != CGAL::POSITIVE && s[2] != CGAL::POSITIVE;
  }
  if (!all_inside) {
    const Epick::Tetrahedron_3 tetrahedron(p.nodes[0], p.nodes[1], p.nodes[2], p.nodes[3]);
    if (!CGAL::do_intersect(triangle, tetrahedron)) return PairStatus::Miss;
  }
  for (int f = 0; f < 4; ++f) {
    const auto* s = p.side[f];
    const bool in_face_plane = s[0] == CGAL::ZERO && s[1] == CGAL::ZERO && s[2] == CGAL::ZERO;
    if (in_face_plane && !faces.is_boundary(faces.tet_faces(f, tet)) &&
        CGAL::orientation(triangle[0], triangle[1], triangle[2], p.nodes[f]) == CGAL::POSITIVE) {
      return PairStatus::Dropped;  // the tet is in front of the triangle: outside the solid here
    }
  }
  return PairStatus::Hit;
}

/// Barycentric coordinates of the triangle's vertices w.r.t. the tet, with the exact
/// signs: β_f is the (scaled) signed distance to face f, positive inside; a vertex in
/// the face's plane gets exactly 0, and rounding never flips a sign.
Eigen::Matrix<double, 4, 3> exact_signed_barycentric(const SurfaceMesh& mesh, const TetMesh& cage, TriangleIndex tri,
                                                     TetIndex tet) {
  const PairSides p = pair_sides(render_triangle(mesh, tri), cage, tet);
  const TetBarycentricFrame frame(cage.rest_positions.col(cage.tets(0, tet)), cage.rest_positions.col(cage.tets(1, tet)),
                                  cage.rest_positions.col(cage.tets(2, tet)), cage.rest_positions.col(cage.tets(3, tet)));
  Eigen::Matrix<double, 4, 3> beta;
  for (int j = 0; j < 3; ++j) {
    Vec4 b = frame.coordinates(mesh.positions.col(mesh.triangles(j, tri)));
    for (int f = 0; f < 4; ++f) {
      if (p.side[f][j] == CGAL::ZERO) {
        b[f] = 0.0;
      } else if (p.side[f][j] == CGAL::NEGATIVE ? !(b[f] > 0.0) : !(b[f] < 0.0)) {
        b[f] = p.side[f][j] == CGAL::NEGATIVE ? std::numeric_limits<double>::denorm_min()
                                              : -std::numeric_limits<double>::denorm_min();
      }
    }
    beta.col(j) = b;
  }
  return beta;
}

}  // namespace

TriangleTetPairs assign_triangles(const SurfaceMesh& mesh, const TetMesh& cage, const CageFaces& faces) {
  TriangleTetPairs result;
  const auto start = std::chrono::steady_clock::now();
  std::vector<Box> triangle_boxes, tet_boxes;
  triangle_boxes.reserve(mesh.triangle_count());
  std::vector<std::uint8_t> degenerate(mesh.triangle_count(), 0);
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    const auto tri = render_triangle(mesh, t);
    if (CGAL::collinear(tri[0], tri[1], tri[2])) {
      degenerate[t] = 1;
      ++result.degenerate_triangles;
      continue;
    }
    triangle_boxes.push_back(make_box<3>(mesh.positions, mesh.triangles.col(t), t));
  }
  tet_boxes.reserve(cage.tet_count());
  for (Index t = 0; t < cage.tet_count(); ++t) tet_boxes.push_back(make_box<4>(cage.rest_positions, cage.tets.col(t), t));

  // Box overlap culls the candidates to those near each other: O((n + k) log n)
  // instead of the thesis's all-pairs loop. Triangles are cut into contiguous chunks
  // whose box intersections run in parallel (box_intersection_d reorders its ranges,
  // so each chunk has its own copy of the tet boxes); each chunk's pairs are sorted
  // and the chunks concatenated in order, so the result is the same for any thread count.
  constexpr std::size_t kChunk = 1 << 14;
  const std::size_t chunks = (triangle_boxes.size() + kChunk - 1) / kChunk;
  std::vector<std::vector<std::pair<TriangleIndex, TetIndex>>> chunk_pairs(chunks);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::vector<Box> tris(triangle_boxes.begin() + static_cast<std::ptrdiff_t>(c * kChunk),
                          triangle_boxes.begin() + static_cast<std::ptrdiff_t>(std::min(triangle_boxes.size(), (c + 1) * kChunk)));
    std::vector<Box> tets = tet_boxes;
    auto& pairs = chunk_pairs[c];
    CGAL::box_intersection_d(tris.begin(), tris.end(), tets.begin(), tets.end(),
                             [&](const Box& tri, const Box& tet) { pairs.emplace_back(tri.info(), tet.info()); });
    std::sort(pairs.begin(), pairs.end());
  });
  std::size_t total = 0;
  for (const auto& pairs : chunk_pairs) total += pairs.size();
  std::vector<std::pair<TriangleIndex, TetIndex>> candidates;
  candidates.reserve(total);
  for (auto& pairs : chunk_pairs) {
    candidates.insert(candidates.end(), pairs.begin(), pairs.end());
    std::vector<std::pair<TriangleIndex, TetIndex>>().swap(pairs);
  }
  result.candidates = candidates.size();
  log_debug("assign: " + std::to_string(candidates.size()) + " box-overlap candidates in " +
            std::to_string(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()) + " s");

  // Pass 1: which candidates intersect (one status byte each, in candidate order,
  // so the result does not depend on the thread count).
  std::vector<PairStatus> status(candidates.size(), PairStatus::Miss);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, candidates.size(), 512), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      status[i] = classify_pair(mesh, cage, faces, candidates[i].first, candidates[i].second);
    }
  });
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    result.coplanar_dropped += status[i] == PairStatus::Dropped;
    if (status[i] != PairStatus::Hit) continue;
    result.triangle.push_back(candidates[i].first);
    result.tet.push_back(candidates[i].second);
  }
  // Pass 2: barycentric coordinates for the hits only (a 4×3 matrix per candidate
  // would dominate the bake's peak memory).
  result.barycentric.resize(result.triangle.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, result.triangle.size(), 512), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      result.barycentric[i] = exact_signed_barycentric(mesh, cage, result.triangle[i], result.tet[i]);
    }
  });
  return result;
}

namespace {

/// Where a render triangle T crosses a cage face F: the segment T ∩ F.
///
/// Exact predicates on the input points decide the combinatorics: each end point is
/// either where an edge of T pierces F (or a vertex of T lying in F), or where an
/// edge of F pierces T (or a vertex of F lying in T). Only then are the points
/// constructed in double, each from its feature in a canonical order (edge end
/// points by index; the plane from the other triangle's vertices in their stored
/// order), so the end point that two neighbouring triangles (or two faces sharing an
/// edge) have in common comes out as the same double in both: contours chain
/// bit-exactly. This is ~30× faster than Epeck constructions rounded from the exact
/// value, which the rare degenerate configurations still use.
struct SegmentResult {
  enum class Kind { None, Segment, NeedsExact } kind = Kind::None;
  Eigen::Matrix<double, 3, 2> points = Eigen::Matrix<double, 3, 2>::Zero();
  std::array<std::uint8_t, 2> features{kContourInterior, kContourInterior};
};

/// Prefers the more specific of two tags for the same point: vertex > edge > interior.
std::uint8_t merge_features(std::uint8_t a, std::uint8_t b) {
  auto rank = [](std::uint8_t f) { return f == kContourInterior ? 0 : (f < 3 ? 1 : 2); };
  return rank(b) > rank(a) ? b : a;
}

/// Feature of the face a point lies on, from which of the three edge tests are zero
/// (edge k runs from face node k to node k+1).
std::uint8_t feature_from_edges(bool on0, bool on1, bool on2) {
  if (on0 && on1) return 3 + 1;
  if (on1 && on2) return 3 + 2;
  if (on2 && on0) return 3 + 0;
  if (on0) return 0;
  if (on1) return 1;
  if (on2) return 2;
  return kContourInterior;
}

bool lexicographically_less(const Vec3& a, const Vec3& b) {
  return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
}

Vec3 edge_plane_point(Vec3 lo, Vec3 hi, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a);
  const double d_lo = n.dot(lo - a), d_hi = n.dot(hi - a);
  const double t = std::clamp(d_lo / (d_lo - d_hi), 0.0, 1.0);
  return lo + t * (hi - lo);
}

/// Whether the line through p, q passes through the closed triangle (a, b, c); if so,
/// `feature` says which edge or vertex of the triangle it passes through, if any.
bool line_pierces(const Point& p, const Point& q, const Point& a, const Point& b, const Point& c,
                  std::uint8_t* feature = nullptr) {
  const CGAL::Orientation s[3] = {CGAL::orientation(p, q, a, b), CGAL::orientation(p, q, b, c), CGAL::orientation(p, q, c, a)};
  const bool any_positive = s[0] == CGAL::POSITIVE || s[1] == CGAL::POSITIVE || s[2] == CGAL::POSITIVE;
  const bool any_negative = s[0] == CGAL::NEGATIVE || s[1] == CGAL::NEGATIVE || s[2] == CGAL::NEGATIVE;
  if (feature) *feature = feature_from_edges(s[0] == CGAL::ZERO, s[1] == CGAL::ZERO, s[2] == CGAL::ZERO);
  return !(any_positive && any_negative);
}

/// Whether x, lying in the plane of (a, b, c), is inside the closed triangle; if so,
/// `feature` says which edge or vertex it lies on, if any.
bool coplanar_inside(const Point& a, const Point& b, const Point& c, const Point& x, std::uint8_t* feature = nullptr) {
  const CGAL::Orientation s[3] = {CGAL::coplanar_orientation(a, b, c, x), CGAL::coplanar_orientation(b, c, a, x),
                                  CGAL::coplanar_orientation(c, a, b, x)};
  if (feature) *feature = feature_from_edges(s[0] == CGAL::COLLINEAR, s[1] == CGAL::COLLINEAR, s[2] == CGAL::COLLINEAR);
  return s[0] != CGAL::NEGATIVE && s[1] != CGAL::NEGATIVE && s[2] != CGAL::NEGATIVE;
}

/// Merges candidate points within `scale` × 1e-12 of an earlier one (their features
/// combined) in place; returns how many distinct points are left at the front.
int merge_near_duplicates(Vec3* candidates, std::uint8_t* features, int count, double scale) {
  int unique = 0;
  for (int k = 0; k < count; ++k) {
    int duplicate_of = -1;
    for (int j = 0; j < unique && duplicate_of < 0; ++j) {
      if ((candidates[j] - candidates[k]).norm() <= 1e-12 * scale) duplicate_of = j;
    }
    if (duplicate_of >= 0) {
      features[duplicate_of] = merge_features(features[duplicate_of], features[k]);
    } else {
      features[unique] = features[k];
      candidates[unique++] = candidates[k];
    }
  }
  return unique;
}

/// The segment between the two candidates, oriented so that direction · (n_F × n_T) > 0
/// puts the solid on the left (see the header); NeedsExact where that sign is unclear.
SegmentResult oriented_segment(const Vec3* candidates, const std::uint8_t* features, const Vec3* f_pos,
                               const Vec3* t_pos) {
  SegmentResult result;
  const Vec3 axis = (f_pos[1] - f_pos[0]).cross(f_pos[2] - f_pos[0]).cross((t_pos[1] - t_pos[0]).cross(t_pos[2] - t_pos[0]));
  const Vec3 direction = candidates[1] - candidates[0];
  const double along = direction.dot(axis);
  if (!(std::abs(along) > 1e-9 * direction.norm() * axis.norm())) {
    result.kind = SegmentResult::Kind::NeedsExact;
    return result;
  }
  result.kind = SegmentResult::Kind::Segment;
  result.points.col(0) = along > 0 ? candidates[0] : candidates[1];
  result.points.col(1) = along > 0 ? candidates[1] : candidates[0];
  result.features = along > 0 ? std::array<std::uint8_t, 2>{features[0], features[1]}
                              : std::array<std::uint8_t, 2>{features[1], features[0]};
  return result;
}

SegmentResult face_triangle_segment(const SurfaceMesh& mesh, TriangleIndex tri, const Matrix3Xd& nodes,
                                    const Eigen::Matrix<Index, 3, 1>& face) {
  Index tv[3];
  Point T[3], F[3];
  Vec3 t_pos[3], f_pos[3];
  for (int k = 0; k < 3; ++k) {
    tv[k] = mesh.triangles(k, tri);
    T[k] = to_point(mesh.positions, tv[k]);
    F[k] = to_point(nodes, face[k]);
    t_pos[k] = mesh.positions.col(tv[k]);
    f_pos[k] = nodes.col(face[k]);
  }
  CGAL::Orientation o_t[3], o_f[3];
  for (int k = 0; k < 3; ++k) {
    o_t[k] = CGAL::orientation(F[0], F[1], F[2], T[k]);
    o_f[k] = CGAL::orientation(T[0], T[1], T[2], F[k]);
  }
  // An edge of T lying in F's plane is shared with the neighbouring triangle, which
  // would report the same segment. Keep it only from the triangle whose third vertex
  // is on the negative side: a surface crossing the plane there then yields it once,
  // and one folding back to touch the plane yields it twice with opposite directions
  // (cancelling) or not at all — the inside region is right in every case.
  {
    int zeros = 0, positive = 0;
    for (int k = 0; k < 3; ++k) {
      zeros += o_t[k] == CGAL::ZERO;
      positive += o_t[k] == CGAL::POSITIVE;
    }
    if (zeros == 2 && positive == 1) return {};
  }
  Vec3 candidates[12];
  std::uint8_t features[12];
  int count = 0;
  for (int k = 0; k < 3; ++k) {
    const int l = (k + 1) % 3;
    std::uint8_t feature = kContourInterior;
    // T's features against F.
    if (o_t[k] == CGAL::ZERO && coplanar_inside(F[0], F[1], F[2], T[k], &feature)) {
      features[count] = feature;
      candidates[count++] = t_pos[k];
    }
    if (o_t[k] * o_t[l] < 0 && line_pierces(T[k], T[l], F[0], F[1], F[2], &feature)) {
      // Order by position, not index: across a UV seam the neighbour has other indices.
      const bool in_order = lexicographically_less(t_pos[k], t_pos[l]);
      features[count] = feature;
      candidates[count++] = edge_plane_point(in_order ? t_pos[k] : t_pos[l], in_order ? t_pos[l] : t_pos[k], f_pos[0],
                                             f_pos[1], f_pos[2]);
    }
    // F's features against T.
    if (o_f[k] == CGAL::ZERO && coplanar_inside(T[0], T[1], T[2], F[k])) {
      features[count] = static_cast<std::uint8_t>(3 + k);
      candidates[count++] = f_pos[k];
    }
    if (o_f[k] * o_f[l] < 0 && line_pierces(F[k], F[l], T[0], T[1], T[2])) {
      const bool in_order = face[k] < face[l];
      features[count] = static_cast<std::uint8_t>(k);
      candidates[count++] = edge_plane_point(in_order ? f_pos[k] : f_pos[l], in_order ? f_pos[l] : f_pos[k], t_pos[0],
                                             t_pos[1], t_pos[2]);
    }
  }
  // A point found through two features (an edge of T meeting an edge of F) is a
  // degenerate case: merge near-duplicates, and leave anything odd to exact arithmetic.
  const double scale = (f_pos[1] - f_pos[0]).norm() + (f_pos[2] - f_pos[0]).norm();
  const int unique = merge_near_duplicates(candidates, features, count, scale);
  SegmentResult result;
  if (unique < 2) return result;  // touching at a point at most
  if (unique > 2) {
    result.kind = SegmentResult::Kind::NeedsExact;
    return result;
  }
  return oriented_segment(candidates, features, f_pos, t_pos);
}

/// Features of the end points of a segment found on the exact path (degenerate
/// configurations only), by their distance to the face's edges and nodes.
std::array<std::uint8_t, 2> features_by_distance(const Eigen::Matrix<double, 3, 2>& segment, const Matrix3Xd& nodes,
                                                 const Eigen::Matrix<Index, 3, 1>& face) {
  std::array<std::uint8_t, 2> out{};
  const double scale = (nodes.col(face[1]) - nodes.col(face[0])).norm() + (nodes.col(face[2]) - nodes.col(face[0])).norm();
  for (int e = 0; e < 2; ++e) {
    const Vec3 p = segment.col(e);
    bool on[3];
    for (int k = 0; k < 3; ++k) {
      const Vec3 a = nodes.col(face[k]), b = nodes.col(face[(k + 1) % 3]);
      on[k] = (p - a).cross(b - a).norm() / (b - a).norm() <= 1e-12 * scale;
    }
    out[static_cast<std::size_t>(e)] = feature_from_edges(on[0], on[1], on[2]);
  }
  return out;
}

/// The exact-construction path for degenerate pairs: Epeck intersection, oriented
/// exactly, rounded from the exact value. Returns false if the overlap is no segment.
bool exact_segment(const SurfaceMesh& mesh, TriangleIndex tri, const Matrix3Xd& nodes,
                   const Eigen::Matrix<Index, 3, 1>& face, Eigen::Matrix<double, 3, 2>& out) {
  const CGAL::Cartesian_converter<Epick, Epeck> to_exact;
  const Epeck::Triangle_3 triangle = to_exact(render_triangle(mesh, tri));
  const Epeck::Point_3 fa = to_exact(to_point(nodes, face[0]));
  const Epeck::Point_3 fb = to_exact(to_point(nodes, face[1]));
  const Epeck::Point_3 fc = to_exact(to_point(nodes, face[2]));
  const auto result = CGAL::intersection(triangle, Epeck::Triangle_3(fa, fb, fc));
  if (!result) return false;
  const Epeck::Segment_3* segment = boost::get<Epeck::Segment_3>(&*result);
  if (segment == nullptr || segment->is_degenerate()) return false;
  const Epeck::Vector_3 n_face = CGAL::cross_product(fb - fa, fc - fa);
  const Epeck::Vector_3 n_tri = CGAL::cross_product(triangle[1] - triangle[0], triangle[2] - triangle[0]);
  const bool flip = CGAL::is_negative((segment->target() - segment->source()) * CGAL::cross_product(n_face, n_tri));
  const Epeck::Point_3& p = flip ? segment->target() : segment->source();
  const Epeck::Point_3& q = flip ? segment->source() : segment->target();
  const auto round = [](const Epeck::FT& x) { return CGAL::to_double(CGAL::exact(x)); };
  out << round(p.x()), round(q.x()), round(p.y()), round(q.y()), round(p.z()), round(q.z());
  return true;
}

/// The (face, triangle) pairs that may cross, sorted and unique. A triangle can only
/// cross face i of its tet if its vertices are not all strictly on one side of the
/// face's plane: an exact orientation test per vertex filters the candidates before the
/// (costlier) exact construction. Marks faces a triangle lies in as degenerate.
std::vector<std::pair<FaceIndex, TriangleIndex>> crossing_candidates(const SurfaceMesh& mesh, const TetMesh& cage,
                                                                     const CageFaces& faces,
                                                                     const TriangleTetPairs& pairs,
                                                                     std::vector<std::uint8_t>& degenerate,
                                                                     std::size_t& coplanar) {
  std::vector<std::pair<FaceIndex, TriangleIndex>> crossing;
  for (std::size_t i = 0; i < pairs.triangle.size(); ++i) {
    const TriangleIndex tri = pairs.triangle[i];
    const TetIndex tet = pairs.tet[i];
    const auto triangle = render_triangle(mesh, tri);
    for (int f = 0; f < 4; ++f) {
      const auto& local = kTetFaceNodes[static_cast<std::size_t>(f)];
      const Point a = to_point(cage.rest_positions, cage.tets(local[0], tet));
      const Point b = to_point(cage.rest_positions, cage.tets(local[1], tet));
      const Point c = to_point(cage.rest_positions, cage.tets(local[2], tet));
      int positive = 0, negative = 0;
      for (int k = 0; k < 3; ++k) {
        const auto side = CGAL::orientation(a, b, c, triangle[k]);
        positive += side == CGAL::POSITIVE;
        negative += side == CGAL::NEGATIVE;
      }
      if (positive == 0 && negative == 0) {
        // The triangle lies in the face's plane.
        degenerate[faces.tet_faces(f, tet)] = 1;
        ++coplanar;
        continue;
      }
      if (positive == 3 || negative == 3) continue;
      crossing.emplace_back(faces.tet_faces(f, tet), tri);
    }
  }
  std::sort(crossing.begin(), crossing.end());
  crossing.erase(std::unique(crossing.begin(), crossing.end()), crossing.end());
  return crossing;
}

}  // namespace

FaceContours extract_contours(const SurfaceMesh& mesh, const TetMesh& cage, const CageFaces& faces,
                              const TriangleTetPairs& pairs) {
  std::size_t coplanar = 0;
  std::vector<std::uint8_t> degenerate(faces.face_count(), 0);
  const std::vector<std::pair<FaceIndex, TriangleIndex>> crossing =
      crossing_candidates(mesh, cage, faces, pairs, degenerate, coplanar);

  std::vector<std::uint8_t> has_segment(crossing.size(), 0);
  std::vector<Eigen::Matrix<double, 3, 2>> segments(crossing.size());
  std::vector<std::array<std::uint8_t, 2>> features(crossing.size());
  std::atomic<std::size_t> exact_fallbacks{0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, crossing.size(), 256), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const auto [face, tri] = crossing[i];
      const SegmentResult result = face_triangle_segment(mesh, tri, cage.rest_positions, faces.nodes.col(face));
      if (result.kind == SegmentResult::Kind::NeedsExact) {
        ++exact_fallbacks;
        has_segment[i] = exact_segment(mesh, tri, cage.rest_positions, faces.nodes.col(face), segments[i]);
        if (has_segment[i]) features[i] = features_by_distance(segments[i], cage.rest_positions, faces.nodes.col(face));
      } else if (result.kind == SegmentResult::Kind::Segment) {
        segments[i] = result.points;
        features[i] = result.features;
        // An end point can sit within rounding of a face edge without the exact
        // predicates seeing it there (the pierced triangle is the neighbour's, its own
        // piece is shorter than the merge tolerance): tag it by distance then.
        const auto nearby = features_by_distance(segments[i], cage.rest_positions, faces.nodes.col(face));
        for (int end = 0; end < 2; ++end) {
          auto& tag = features[i][static_cast<std::size_t>(end)];
          if (tag == kContourInterior) tag = nearby[static_cast<std::size_t>(end)];
        }
        has_segment[i] = 1;
      }
    }
  });
  if (exact_fallbacks > 0) {
    log_debug("contours: " + std::to_string(exact_fallbacks.load()) + " degenerate pairs took the exact-construction path");
  }

  FaceContours contours;
  contours.coplanar_pairs = coplanar;
  contours.degenerate_faces = std::move(degenerate);
  contours.offsets.assign(faces.face_count() + 1, 0);
  for (std::size_t i = 0; i < crossing.size(); ++i) {
    if (!has_segment[i]) continue;
    ++contours.offsets[crossing[i].first + 1];
    contours.points.push_back(segments[i]);
    contours.features.push_back(features[i]);
    contours.triangle.push_back(crossing[i].second);
  }
  std::partial_sum(contours.offsets.begin(), contours.offsets.end(), contours.offsets.begin());
  return contours;
}

}  // namespace fissure::bake
