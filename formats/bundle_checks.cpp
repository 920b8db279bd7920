#include "formats/bundle_checks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <utility>

#include "common/barycentric.h"

namespace fissure::formats {
namespace {

std::string format_double(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", value);
  return buffer;
}

Eigen::Matrix<double, 3, 4> tet_nodes(const TetMesh& cage, TetIndex t) {
  Eigen::Matrix<double, 3, 4> nodes;
  for (int i = 0; i < 4; ++i) nodes.col(i) = cage.rest_positions.col(cage.tets(i, t));
  return nodes;
}

double bounding_diagonal(const Matrix3Xd& points) {
  if (points.cols() == 0) return 0.0;
  return (points.rowwise().maxCoeff() - points.rowwise().minCoeff()).norm();
}

VerifyCheck check_tets_positive(const TetMesh& cage) {
  VerifyCheck check{"tets-positive", true, ""};
  std::size_t bad = 0;
  for (Index t = 0; t < cage.tet_count(); ++t) {
    if (!(signed_volume(cage, t) > 0.0)) {
      if (bad++ == 0) check.detail = "tet " + std::to_string(t) + " has volume " + format_double(signed_volume(cage, t));
    }
  }
  check.passed = bad == 0;
  check.detail = check.passed ? std::to_string(cage.tet_count()) + " tets, all positive"
                              : std::to_string(bad) + " non-positive tets; first: " + check.detail;
  return check;
}

VerifyCheck check_face_table(const TetMesh& cage, const CageFaces& faces) {
  VerifyCheck check{"face-table", true, ""};
  for (Index t = 0; t < cage.tet_count() && check.passed; ++t) {
    for (int i = 0; i < 4 && check.passed; ++i) {
      const FaceIndex f = faces.tet_faces(i, t);
      std::array<Index, 3> a{}, b{};
      for (int k = 0; k < 3; ++k) {
        a[static_cast<std::size_t>(k)] = cage.tets(kTetFaceNodes[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)], t);
        b[static_cast<std::size_t>(k)] = faces.nodes(k, f);
      }
      std::sort(a.begin(), a.end());
      std::sort(b.begin(), b.end());
      const bool owner = faces.tets(0, f) == t || faces.tets(1, f) == t;
      if (a != b || !owner) {
        check.passed = false;
        check.detail = "tet " + std::to_string(t) + " local face " + std::to_string(i) + " does not match face " +
                       std::to_string(f);
      }
    }
  }
  if (check.passed) check.detail = std::to_string(faces.face_count()) + " faces consistent with the tets";
  return check;
}

/// Whether a face's contour chains are closed: every end point inside the face is
/// the head of one segment and the tail of another (bit-exact, as the bake builds
/// them). An open surface leaves chains ending inside faces, where the inside region
/// has no well-defined boundary.
bool contours_closed(const Embedding& e, FaceIndex f) {
  std::map<std::array<double, 3>, int> balance;
  for (std::uint64_t s = e.contour_offsets[f]; s < e.contour_offsets[f + 1]; ++s) {
    for (int end = 0; end < 2; ++end) {
      if (e.contour_feature[s][static_cast<std::size_t>(end)] != kContourInterior) continue;
      const Vec3 p = e.contour_points[s].col(end);
      balance[{p.x(), p.y(), p.z()}] += end == 0 ? 1 : -1;
    }
  }
  return std::all_of(balance.begin(), balance.end(), [](const auto& entry) { return entry.second == 0; });
}

/// How far face f's tile's texel count is from the exact inside area, in texel rows
/// along the region's boundary (contour and face edges): at most 1 for a good tile.
double tile_area_error_rows(const Bundle& b, FaceIndex f, double area) {
  const Walls& w = *b.walls;
  const Embedding& e = b.embedding;
  const Vec3 n0 = b.cage.rest_positions.col(b.faces.nodes(0, f));
  const double e1 = (b.cage.rest_positions.col(b.faces.nodes(1, f)) - n0).norm();
  const double e2 = (b.cage.rest_positions.col(b.faces.nodes(2, f)) - n0).norm();
  const double e3 = (b.cage.rest_positions.col(b.faces.nodes(2, f)) - b.cage.rest_positions.col(b.faces.nodes(1, f))).norm();
  double boundary = e1 + e2 + e3;
  for (std::uint64_t s = e.contour_offsets[f]; s < e.contour_offsets[f + 1]; ++s) {
    boundary += (e.contour_points[s].col(1) - e.contour_points[s].col(0)).norm();
  }
  const double texel = (e1 + e2) / w.resolution;
  return std::abs(tile_inside_area(w, f, area) - w.face_inside_area[f]) / (boundary * texel);
}

/// A tile that more than one face uses, or one out of range; none when every face has its own.
std::optional<Index> shared_tile(const Walls& w, FaceIndex faces) {
  std::vector<std::uint8_t> used(w.tile_count(), 0);
  for (FaceIndex f = 0; f < faces; ++f) {
    const Index tile = w.face_tile[f];
    if (tile == kInvalidIndex) continue;
    if (tile >= used.size() || used[tile]++) return tile;
  }
  return std::nullopt;
}

VerifyCheck check_walls(const Bundle& b) {
  VerifyCheck check{"walls", true, ""};
  const Walls& w = *b.walls;
  const Embedding& e = b.embedding;
  std::size_t crossing = 0, open_faces = 0;
  double worst_ratio = 0.0;
  auto fail = [&](const std::string& detail) {
    if (check.passed) check.detail = detail;
    check.passed = false;
  };
  for (FaceIndex f = 0; f < b.faces.face_count(); ++f) {
    const bool has_contour = e.contour_offsets[f + 1] > e.contour_offsets[f];
    const double area = face_area(b.cage, b.faces, f);
    const FaceClass cls = w.face_class[f];
    if (!w.face_clearance.empty()) {
      const double clearance = w.face_clearance[f];
      if (!(clearance >= 0.0 && std::isfinite(clearance)) || (clearance > 0.0 && cls != FaceClass::Inside)) {
        fail("face " + std::to_string(f) + " of class " + std::to_string(static_cast<int>(cls)) + " has clearance " +
             format_double(clearance) + " (a finite distance ≥ 0, and 0 unless the face is inside the solid)");
        continue;
      }
    }
    if (cls == FaceClass::Degenerate) {
      if (!e.face_degenerate[f]) fail("face " + std::to_string(f) + " is classed degenerate but is not");
      if (w.face_tile[f] != kInvalidIndex) fail("degenerate face " + std::to_string(f) + " has a tile");
      continue;
    }
    if ((cls == FaceClass::Crossing) != has_contour) {
      fail("face " + std::to_string(f) + " is classed " + std::to_string(static_cast<int>(cls)) + " but has " +
           (has_contour ? "" : "no ") + "contour");
      continue;
    }
    if ((w.face_tile[f] != kInvalidIndex) != (cls == FaceClass::Crossing)) {
      fail("face " + std::to_string(f) + ": a tile exactly when the face is crossing");
      continue;
    }
    const double inside = w.face_inside_area[f];
    if (!(inside >= 0.0 && inside <= area * (1.0 + 1e-9)) || (cls == FaceClass::Inside && std::abs(inside - area) > 1e-9 * area) ||
        (cls == FaceClass::Outside && inside != 0.0)) {
      fail("face " + std::to_string(f) + ": inside area " + format_double(inside) + " of " + format_double(area) +
           " does not fit its class " + std::to_string(static_cast<int>(cls)));
      continue;
    }
    if (cls != FaceClass::Crossing) continue;
    ++crossing;
    if (!contours_closed(e, f)) {
      ++open_faces;  // an open surface ends inside this face: no exact area to compare with
      continue;
    }
    if (e.surface_self_intersections > 0) continue;  // overlapping regions: see Embedding
    const double rows = tile_area_error_rows(b, f, area);
    worst_ratio = std::max(worst_ratio, rows);
    if (rows > 1.0) {
      fail("face " + std::to_string(f) + ": its tile covers " + format_double(tile_inside_area(w, f, area)) +
           " but the exact inside area is " + format_double(inside) + " (more than a texel row off)");
    }
  }
  if (w.tile_count() != crossing && check.passed) fail(std::to_string(w.tile_count()) + " tiles for " + std::to_string(crossing) + " crossing faces");
  if (check.passed) {
    if (const std::optional<Index> shared = shared_tile(w, b.faces.face_count())) {
      fail("tile " + std::to_string(*shared) + " is used by more than one face");
    }
  }
  if (check.passed) {
    check.detail = std::to_string(crossing) + " tiles of " + std::to_string(w.resolution) + "²; ";
    if (e.surface_self_intersections > 0) {
      check.detail += "tile areas not compared: the surface crosses itself";
    } else {
      check.detail += "worst tile-area error " + format_double(worst_ratio) + " texel rows";
    }
    if (open_faces > 0) check.detail += " (" + std::to_string(open_faces) + " faces with open contours not compared)";
  }
  return check;
}

/// Whether a sphere's centre is within the target radius of each face's plane of its
/// tet (a surface sphere is centred up to that far from the surface point its tet
/// holds) and its radius in (0, target]. The distance to the plane of the face opposite
/// corner i is βᵢ times that corner's height 3V / Aᵢ.
bool sphere_fits(const Bundle& b, TetIndex t, const Vec4& beta, double radius) {
  const double target = b.collision->target_radius;
  Vec3 x[4];
  for (int i = 0; i < 4; ++i) x[i] = b.cage.rest_positions.col(b.cage.tets(i, t));
  const double six_volume = std::abs((x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0])));
  bool reaches = six_volume > 0.0;
  for (int i = 0; i < 4 && reaches; ++i) {
    const Vec3 &p = x[(i + 1) % 4], &q = x[(i + 2) % 4], &r = x[(i + 3) % 4];
    const double height = six_volume / (q - p).cross(r - p).norm();
    reaches = beta[i] * height >= -target * (1 + 1e-9) - 1e-12 * height;
  }
  return reaches && std::abs(beta.sum() - 1.0) <= 1e-12 && radius > 0.0 && radius <= target * (1 + 1e-12);
}

VerifyCheck check_spheres(const Bundle& b) {
  VerifyCheck check{"collision-spheres", true, ""};
  const Collision& c = *b.collision;
  const auto check_set = [&](const std::string& kind, const std::vector<TetIndex>& tet, const std::vector<Vec4>& beta,
                             const std::vector<double>& radius) {
    for (std::size_t s = 0; s < tet.size() && check.passed; ++s) {
      if (sphere_fits(b, tet[s], beta[s], radius[s])) continue;
      check.passed = false;
      check.detail = kind + " " + std::to_string(s) + " of tet " + std::to_string(tet[s]) +
                     " is centred farther than the target radius from its tet, or has a bad radius";
    }
  };
  check_set("sphere", c.sphere_tet, c.sphere_barycentric, c.sphere_radius);
  check_set("reserve sphere", c.reserve_tet, c.reserve_barycentric, c.reserve_radius);
  if (check.passed) {
    check.detail = std::to_string(c.sphere_tet.size()) + " spheres and " + std::to_string(c.reserve_tet.size()) +
                   " in reserve centred within the target radius of their tets, radii ≤ the target " +
                   format_double(c.target_radius);
  }
  return check;
}

VerifyCheck check_mass(const Bundle& b) {
  VerifyCheck check{"collision-mass", true, ""};
  const Collision& c = *b.collision;
  double solid = 0.0;
  for (Index t = 0; t < b.cage.tet_count() && check.passed; ++t) {
    const double f = c.mass_fraction[t];
    const auto cls = b.embedding.tet_class[t];
    const bool fits = f >= 0.0 && f <= 1.0 && (cls != TetClass::Inside || f == 1.0) && (cls != TetClass::Outside || f == 0.0) &&
                      std::abs(c.center_of_mass[t].sum() - 1.0) <= 1e-9 && (f == 0.0 || c.center_of_mass[t].minCoeff() >= -1e-9);
    if (!fits) {
      check.passed = false;
      check.detail = "tet " + std::to_string(t) + ": mass fraction " + format_double(f) +
                     " or centre of mass does not fit its class";
    }
    solid += f * signed_volume(b.cage, t);
  }
  if (!check.passed) return check;
  // On a closed surface the solid parts of the tets add up to the enclosed volume
  // (unless some were sampled beside faces the surface lies in).
  if (c.sampled_tets > 0) {
    check.detail = "fractions in [0, 1] and consistent with the tet classes; " + std::to_string(c.sampled_tets) +
                   " tets beside faces the surface lies in were sampled, so the total is not compared";
  } else if (b.embedding.surface_self_intersections > 0) {
    check.detail = "fractions in [0, 1] and consistent with the tet classes; the surface crosses itself (" +
                   std::to_string(b.embedding.surface_self_intersections) +
                   " triangle pairs), so the total is not compared with its enclosed volume";
  } else if (analyze_topology(b.render).closed()) {
    const double enclosed = enclosed_volume(b.render);
    const double error = std::abs(solid - enclosed) / std::max(std::abs(enclosed), 1e-300);
    check.passed = error <= 1e-9;
    check.detail = "Σ fraction·volume = " + format_double(solid) + " vs enclosed volume " + format_double(enclosed) +
                   " (relative error " + format_double(error) + ")";
  } else {
    check.detail = "fractions in [0, 1] and consistent with the tet classes (open surface: no volume to compare)";
  }
  return check;
}

}  // namespace

bool VerifyReport::passed() const {
  return std::all_of(checks.begin(), checks.end(), [](const VerifyCheck& c) { return c.passed; });
}

std::vector<double> covered_area(const SurfaceMesh& render, const TetMesh& cage, const Embedding& embedding) {
  std::vector<double> covered(render.triangle_count(), 0.0);
  for (std::size_t i = 0; i < embedding.instance_count(); ++i) {
    const auto polygon = clip_to_tet(embedding.instance_barycentric[i]);
    covered[embedding.instance_triangle[i]] += polygon_area(polygon, tet_nodes(cage, embedding.instance_tet[i]));
  }
  return covered;
}

double tile_inside_area(const Walls& w, FaceIndex face, double area) {
  const Index tile = w.face_tile[face];
  if (tile == kInvalidIndex) return w.face_class[face] == FaceClass::Inside ? area : 0.0;
  const std::size_t res = w.resolution;
  const std::uint8_t* sdf = &w.sdf[tile * res * res];
  std::size_t inside = 0;
  for (std::size_t j = 0; j < res; ++j) {
    for (std::size_t i = 0; i < res; ++i) {
      if ((i + 0.5) + (j + 0.5) <= static_cast<double>(res) && sdf[j * res + i] >= 128) ++inside;
    }
  }
  // Each texel covers 1/res² of the parallelogram spanned by the edges, i.e. 2/res²
  // of the face.
  return static_cast<double>(inside) * 2.0 * area / static_cast<double>(res * res);
}

double enclosed_volume(const SurfaceMesh& mesh) {
  double volume = 0.0;
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3 a = mesh.positions.col(mesh.triangles(0, t));
    volume += a.dot(mesh.positions.col(mesh.triangles(1, t)).cross(mesh.positions.col(mesh.triangles(2, t)))) / 6.0;
  }
  return volume;
}

namespace {

/// Each instance's barycentric coordinates sum to 1 and rebuild its triangle's vertices.
std::pair<VerifyCheck, VerifyCheck> check_barycentrics(const Bundle& b, const VerifyTolerances& tol, double diagonal) {
  const Embedding& e = b.embedding;
  VerifyCheck sums{"barycentric-sums", true, ""};
  VerifyCheck rebuild{"barycentric-reconstruction", true, ""};
  double worst_sum = 0.0, worst_rebuild = 0.0;
  for (std::size_t i = 0; i < e.instance_count(); ++i) {
    const auto nodes = tet_nodes(b.cage, e.instance_tet[i]);
    for (int j = 0; j < 3; ++j) {
      const Vec4 beta = e.instance_barycentric[i].col(j);
      // Relative to the coordinates' size: a big triangle over small tets has large β.
      const double sum_error = std::abs(beta.sum() - 1.0) / std::max(1.0, beta.cwiseAbs().sum());
      const Vec3 vertex = b.render.positions.col(b.render.triangles(j, e.instance_triangle[i]));
      const double rebuild_error = (nodes * beta - vertex).norm() / diagonal;
      if (!(sum_error <= tol.barycentric_sum) && sums.passed) {
        sums.passed = false;
        sums.detail = "instance " + std::to_string(i) + " vertex " + std::to_string(j) + ": sum off by " +
                      format_double(sum_error);
      }
      if (!(rebuild_error <= tol.reconstruction) && rebuild.passed) {
        rebuild.passed = false;
        rebuild.detail = "instance " + std::to_string(i) + " (triangle " + std::to_string(e.instance_triangle[i]) +
                         ", tet " + std::to_string(e.instance_tet[i]) + ") vertex " + std::to_string(j) +
                         ": off by " + format_double(rebuild_error) + " of the cage diagonal";
      }
      worst_sum = std::max(worst_sum, sum_error);
      worst_rebuild = std::max(worst_rebuild, rebuild_error);
    }
  }
  if (sums.passed) sums.detail = "max |Σβ−1| = " + format_double(worst_sum);
  if (rebuild.passed) rebuild.detail = "max error = " + format_double(worst_rebuild) + " of the cage diagonal";
  return {sums, rebuild};
}

/// The instances of each triangle cover exactly its area.
VerifyCheck check_coverage(const Bundle& b, const VerifyTolerances& tol) {
  const Embedding& e = b.embedding;
  VerifyCheck coverage{"area-coverage", true, ""};
  const std::vector<double> covered = covered_area(b.render, b.cage, e);
  double worst = 0.0;
  std::size_t failing = 0;
  for (Index t = 0; t < b.render.triangle_count(); ++t) {
    const double area = triangle_area(b.render, t);
    if (is_degenerate(b.render, t)) continue;
    const double error = std::abs(covered[t] - area) / area;
    worst = std::max(worst, error);
    if (!(error <= tol.coverage)) {
      if (failing++ == 0) {
        coverage.detail = "triangle " + std::to_string(t) + ": instances cover " + format_double(covered[t]) +
                          " of its area " + format_double(area);
      }
    }
  }
  coverage.passed = failing == 0;
  coverage.detail = coverage.passed ? "max relative error = " + format_double(worst)
                                    : std::to_string(failing) + " triangles not exactly covered; first: " + coverage.detail;
  return coverage;
}

/// Node inside flags agree with their winding numbers, tet classes with their instances.
VerifyCheck check_classes(const Bundle& b) {
  const Embedding& e = b.embedding;
  VerifyCheck classes{"node-classes", true, ""};
  for (std::size_t n = 0; n < e.node_inside.size() && classes.passed; ++n) {
    if ((e.node_winding[n] >= 0.5) != (e.node_inside[n] != 0) || !std::isfinite(e.node_winding[n])) {
      classes.passed = false;
      classes.detail = "node " + std::to_string(n) + ": winding " + format_double(e.node_winding[n]) +
                       " disagrees with its inside flag";
    }
  }
  std::vector<bool> has_instance(b.cage.tet_count(), false);
  for (const TetIndex t : e.instance_tet) has_instance[t] = true;
  for (Index t = 0; t < b.cage.tet_count() && classes.passed; ++t) {
    if (has_instance[t] != (e.tet_class[t] == TetClass::Crossing)) {
      classes.passed = false;
      classes.detail = "tet " + std::to_string(t) + " is classed " +
                       std::to_string(static_cast<int>(e.tet_class[t])) + " but has " +
                       (has_instance[t] ? "" : "no ") + "instances";
    }
  }
  if (classes.passed) classes.detail = "node flags match winding numbers; tet classes match instances";
  return classes;
}

/// Every contour segment lies on its cage face and on its triangle.
VerifyCheck check_contours(const Bundle& b, const VerifyTolerances& tol, double diagonal) {
  const Embedding& e = b.embedding;
  VerifyCheck contours{"contours-on-faces", true, ""};
  double worst = 0.0;
  for (FaceIndex f = 0; f < b.faces.face_count() && contours.passed; ++f) {
    const Vec3 a = b.cage.rest_positions.col(b.faces.nodes(0, f));
    const Vec3 n = (b.cage.rest_positions.col(b.faces.nodes(1, f)) - a)
                       .cross(b.cage.rest_positions.col(b.faces.nodes(2, f)) - a)
                       .normalized();
    for (std::uint64_t s = e.contour_offsets[f]; s < e.contour_offsets[f + 1]; ++s) {
      const TriangleIndex tri = e.contour_triangle[s];
      const Vec3 ta = b.render.positions.col(b.render.triangles(0, tri));
      const Vec3 tn = (b.render.positions.col(b.render.triangles(1, tri)) - ta)
                          .cross(b.render.positions.col(b.render.triangles(2, tri)) - ta)
                          .normalized();
      for (int k = 0; k < 2; ++k) {
        const Vec3 p = e.contour_points[s].col(k);
        const double off = std::max(std::abs(n.dot(p - a)), std::abs(tn.dot(p - ta))) / diagonal;
        worst = std::max(worst, off);
        if (!(off <= tol.contour)) {
          contours.passed = false;
          contours.detail = "segment " + std::to_string(s) + " of face " + std::to_string(f) + " lies " +
                            format_double(off) + " of the diagonal off its face or triangle plane";
        }
      }
    }
  }
  if (contours.passed) {
    contours.detail = std::to_string(e.segment_count()) + " segments, max plane offset " + format_double(worst);
  }
  return contours;
}

}  // namespace

std::vector<std::size_t> replication_histogram(std::size_t triangle_count, const Embedding& embedding) {
  std::vector<std::size_t> per_triangle(triangle_count, 0);
  for (const TriangleIndex t : embedding.instance_triangle) ++per_triangle[t];
  std::vector<std::size_t> histogram(9, 0);
  for (const std::size_t count : per_triangle) ++histogram[std::min<std::size_t>(count, 8)];
  return histogram;
}

VerifyReport verify_bundle(const Bundle& b, const VerifyTolerances& tol) {
  VerifyReport report;
  const double diagonal = std::max(bounding_diagonal(b.cage.rest_positions), 1e-300);
  report.checks.push_back(check_tets_positive(b.cage));
  report.checks.push_back(check_face_table(b.cage, b.faces));
  const auto [sums, rebuild] = check_barycentrics(b, tol, diagonal);
  report.checks.push_back(sums);
  report.checks.push_back(rebuild);
  report.checks.push_back(check_coverage(b, tol));
  report.checks.push_back(check_classes(b));
  report.checks.push_back(check_contours(b, tol, diagonal));
  if (b.walls) {
    report.checks.push_back(check_walls(b));
  }
  if (b.collision) {
    report.checks.push_back(check_spheres(b));
    report.checks.push_back(check_mass(b));
  }
  return report;
}

}  // namespace fissure::formats
