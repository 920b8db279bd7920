// One of the few translation units that include CGAL (builds are slow; keep it so).
#include "bake/exact_embedding.h"

#include "common/barycentric.h"

#include <CGAL/Cartesian_converter.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/intersections.h>
#include <tbb/parallel_for.h>

#include <algorithm>
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

/// Classifies a confirmed (triangle, tet) pair: returns false if the triangle lies in
/// an interior face of the tet and faces into it (the neighbour behind it keeps it);
/// otherwise fills the exact-signed barycentric coordinates.
bool classify_pair(const SurfaceMesh& mesh, const TetMesh& cage, const CageFaces& faces, TriangleIndex tri,
                   TetIndex tet, Eigen::Matrix<double, 4, 3>& beta) {
  const auto triangle = render_triangle(mesh, tri);
  Point nodes[4];
  for (int i = 0; i < 4; ++i) nodes[i] = to_point(cage.rest_positions, cage.tets(i, tet));
  // side[f][j]: vertex j relative to face f's plane; the tet's inside is NEGATIVE
  // for outward-ordered faces.
  CGAL::Orientation side[4][3];
  for (int f = 0; f < 4; ++f) {
    const auto& local = kTetFaceNodes[static_cast<std::size_t>(f)];
    for (int j = 0; j < 3; ++j) side[f][j] = CGAL::orientation(nodes[local[0]], nodes[local[1]], nodes[local[2]], triangle[j]);
    const bool in_face_plane = side[f][0] == CGAL::ZERO && side[f][1] == CGAL::ZERO && side[f][2] == CGAL::ZERO;
    if (in_face_plane && !faces.is_boundary(faces.tet_faces(f, tet)) &&
        CGAL::orientation(triangle[0], triangle[1], triangle[2], nodes[f]) == CGAL::POSITIVE) {
      return false;  // the tet is in front of the triangle: outside the solid here
    }
  }
  const TetBarycentricFrame frame(cage.rest_positions.col(cage.tets(0, tet)), cage.rest_positions.col(cage.tets(1, tet)),
                                  cage.rest_positions.col(cage.tets(2, tet)), cage.rest_positions.col(cage.tets(3, tet)));
  for (int j = 0; j < 3; ++j) {
    Vec4 b = frame.coordinates(mesh.positions.col(mesh.triangles(j, tri)));
    // β_f is the signed distance to face f (local face f is opposite node f), scaled:
    // positive inside. Make its sign the exact one.
    for (int f = 0; f < 4; ++f) {
      if (side[f][j] == CGAL::ZERO) {
        b[f] = 0.0;
      } else if ((side[f][j] == CGAL::NEGATIVE) != (b[f] > 0.0)) {
        b[f] = side[f][j] == CGAL::NEGATIVE ? std::numeric_limits<double>::denorm_min()
                                            : -std::numeric_limits<double>::denorm_min();
      }
    }
    beta.col(j) = b;
  }
  return true;
}

}  // namespace

TriangleTetPairs assign_triangles(const SurfaceMesh& mesh, const TetMesh& cage, const CageFaces& faces) {
  TriangleTetPairs result;
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
  // instead of the thesis's all-pairs loop.
  std::vector<std::pair<TriangleIndex, TetIndex>> candidates;
  CGAL::box_intersection_d(triangle_boxes.begin(), triangle_boxes.end(), tet_boxes.begin(), tet_boxes.end(),
                           [&](const Box& tri, const Box& tet) { candidates.emplace_back(tri.info(), tet.info()); });
  std::sort(candidates.begin(), candidates.end());
  result.candidates = candidates.size();

  enum : std::uint8_t { kMiss = 0, kHit = 1, kDropped = 2 };
  std::vector<std::uint8_t> hit(candidates.size(), kMiss);
  std::vector<Eigen::Matrix<double, 4, 3>> beta(candidates.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, candidates.size(), 256), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const auto [tri, tet] = candidates[i];
      const Epick::Tetrahedron_3 tetrahedron(
          to_point(cage.rest_positions, cage.tets(0, tet)), to_point(cage.rest_positions, cage.tets(1, tet)),
          to_point(cage.rest_positions, cage.tets(2, tet)), to_point(cage.rest_positions, cage.tets(3, tet)));
      if (!CGAL::do_intersect(render_triangle(mesh, tri), tetrahedron)) continue;
      hit[i] = classify_pair(mesh, cage, faces, tri, tet, beta[i]) ? kHit : kDropped;
    }
  });
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    result.coplanar_dropped += hit[i] == kDropped;
    if (hit[i] != kHit) continue;
    result.triangle.push_back(candidates[i].first);
    result.tet.push_back(candidates[i].second);
    result.barycentric.push_back(beta[i]);
  }
  return result;
}

FaceContours extract_contours(const SurfaceMesh& mesh, const TetMesh& cage, const CageFaces& faces,
                              const TriangleTetPairs& pairs) {
  // A triangle can only cross face i of its tet if its vertices are not all strictly
  // on one side of the face's plane: an exact orientation test per vertex filters the
  // candidates before the (costlier) exact construction.
  std::vector<std::pair<FaceIndex, TriangleIndex>> crossing;
  std::size_t coplanar = 0;
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
        ++coplanar;
        continue;
      }
      if (positive == 3 || negative == 3) continue;
      crossing.emplace_back(faces.tet_faces(f, tet), tri);
    }
  }
  std::sort(crossing.begin(), crossing.end());
  crossing.erase(std::unique(crossing.begin(), crossing.end()), crossing.end());

  // Exact constructions (Epeck) for the segment end points, rounded once to double.
  const CGAL::Cartesian_converter<Epick, Epeck> to_exact;
  std::vector<std::uint8_t> has_segment(crossing.size(), 0);
  std::vector<Eigen::Matrix<double, 3, 2>> segments(crossing.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, crossing.size(), 64), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const auto [face, tri] = crossing[i];
      const Epeck::Triangle_3 triangle = to_exact(render_triangle(mesh, tri));
      const Epeck::Point_3 fa = to_exact(to_point(cage.rest_positions, faces.nodes(0, face)));
      const Epeck::Point_3 fb = to_exact(to_point(cage.rest_positions, faces.nodes(1, face)));
      const Epeck::Point_3 fc = to_exact(to_point(cage.rest_positions, faces.nodes(2, face)));
      const auto result = CGAL::intersection(triangle, Epeck::Triangle_3(fa, fb, fc));
      if (!result) continue;
      const Epeck::Segment_3* segment = boost::get<Epeck::Segment_3>(&*result);
      if (segment == nullptr || segment->is_degenerate()) continue;
      // Orient: direction · (n_face × n_triangle) > 0 puts the solid on the left.
      const Epeck::Vector_3 n_face = CGAL::cross_product(fb - fa, fc - fa);
      const Epeck::Vector_3 n_tri = CGAL::cross_product(triangle[1] - triangle[0], triangle[2] - triangle[0]);
      const bool flip = CGAL::is_negative((segment->target() - segment->source()) * CGAL::cross_product(n_face, n_tri));
      const Epeck::Point_3& p = flip ? segment->target() : segment->source();
      const Epeck::Point_3& q = flip ? segment->source() : segment->target();
      segments[i] << CGAL::to_double(p.x()), CGAL::to_double(q.x()), CGAL::to_double(p.y()), CGAL::to_double(q.y()),
          CGAL::to_double(p.z()), CGAL::to_double(q.z());
      has_segment[i] = 1;
    }
  });

  FaceContours contours;
  contours.coplanar_pairs = coplanar;
  contours.offsets.assign(faces.face_count() + 1, 0);
  for (std::size_t i = 0; i < crossing.size(); ++i) {
    if (!has_segment[i]) continue;
    ++contours.offsets[crossing[i].first + 1];
    contours.points.push_back(segments[i]);
    contours.triangle.push_back(crossing[i].second);
  }
  std::partial_sum(contours.offsets.begin(), contours.offsets.end(), contours.offsets.begin());
  return contours;
}

}  // namespace fissure::bake
