#include "bake/bake.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "bake/exact_embedding.h"
#include "bake/file_hash.h"
#include "bake/repeated_triangles.h"
#include "bake/self_intersections.h"
#include "bake/surface_orientation.h"
#include "bake/winding_number.h"
#include "common/error.h"
#include "common/json_writer.h"
#include "common/log.h"
#include "formats/bundle_checks.h"
#include "formats/cage_io.h"

#ifndef FISSURE_VERSION
#define FISSURE_VERSION "0.0.0"
#endif

namespace fissure::bake {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

/// "name: detail (0.123 s)" at Info level, so long bakes show progress stage by stage.
void log_stage(const char* name, const std::string& detail, double seconds) {
  char timing[32];
  std::snprintf(timing, sizeof timing, " (%.3f s)", seconds);
  log_info(std::string("  ") + name + ": " + detail + timing);
}

std::string format_point(const Vec3& p) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "(%.6g, %.6g, %.6g)", p.x(), p.y(), p.z());
  return buffer;
}

/// Throws when some triangle's area is not covered exactly once by the cage, saying how much and where.
void require_coverage(const SurfaceMesh& mesh, const TetMesh& cage, const formats::Embedding& embedding,
                      double tolerance, const std::string& mesh_name, const std::string& cage_name) {
  const std::vector<double> covered = formats::covered_area(mesh, cage, embedding);
  std::size_t outside_triangles = 0;
  double outside_area = 0.0, total_area = 0.0;
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  TriangleIndex first = kInvalidIndex;
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    const double area = triangle_area(mesh, t);
    total_area += area;
    // Both directions: too little means the cage misses surface; too much means
    // overlapping tets (they count the same surface twice).
    const double missing = std::abs(area - covered[t]);
    if (!is_degenerate(mesh, t) && missing > tolerance * area) {
      ++outside_triangles;
      outside_area += missing;
      if (first == kInvalidIndex) first = t;
      for (int k = 0; k < 3; ++k) {
        lo = lo.cwiseMin(mesh.positions.col(mesh.triangles(k, t)));
        hi = hi.cwiseMax(mesh.positions.col(mesh.triangles(k, t)));
      }
    }
  }
  if (outside_triangles == 0) return;
  char share[32];
  std::snprintf(share, sizeof share, "%.3g%%", 100.0 * outside_area / std::max(total_area, 1e-300));
  char area_text[32];
  std::snprintf(area_text, sizeof area_text, "%.3g", outside_area);
  const Vec3 centroid = (mesh.positions.col(mesh.triangles(0, first)) + mesh.positions.col(mesh.triangles(1, first)) +
                         mesh.positions.col(mesh.triangles(2, first))) / 3.0;
  throw Error(cage_name + " does not cover " + mesh_name + " exactly once: " + std::to_string(outside_triangles) +
                  " triangles lie partly or wholly outside it, or inside overlapping tets (area " + area_text + " m², " + share +
                  " of the surface), within the box " + format_point(lo) + " – " + format_point(hi) +
                  "; first: triangle " + std::to_string(first) + " near " + format_point(centroid),
              "enlarge the cage so it encloses the whole mesh (check both are in the same units and frame), and make "
              "sure its tets do not overlap");
}

/// Every vertex of a triangle lies within the cage's bounding box, or the cage cannot
/// cover the mesh. Checked before the embedding: a vertex far outside (1e15, say) would
/// otherwise reach the exact predicates and fail deep in the bake.
void require_inside_cage_bounds(const SurfaceMesh& mesh, const TetMesh& cage, const std::string& mesh_name,
                                const std::string& cage_name) {
  if (cage.node_count() == 0) throw Error(cage_name + ": the cage has no nodes");
  const Vec3 lo = cage.rest_positions.rowwise().minCoeff(), hi = cage.rest_positions.rowwise().maxCoeff();
  std::vector<std::uint8_t> outside(mesh.vertex_count(), 0);
  for (Eigen::Index i = 0; i < mesh.triangles.size(); ++i) {
    const Index v = mesh.triangles.data()[i];
    const auto p = mesh.positions.col(v).array();
    outside[v] = (p < lo.array()).any() || (p > hi.array()).any();
  }
  const auto first = std::find(outside.begin(), outside.end(), 1);
  if (first == outside.end()) return;
  Vec3 box_lo = Vec3::Constant(std::numeric_limits<double>::infinity()), box_hi = -box_lo;
  for (Index v = 0; v < mesh.vertex_count(); ++v) {
    if (!outside[v]) continue;
    box_lo = box_lo.cwiseMin(mesh.positions.col(v));
    box_hi = box_hi.cwiseMax(mesh.positions.col(v));
  }
  const auto v = static_cast<Index>(first - outside.begin());
  throw Error(cage_name + " does not cover " + mesh_name + ": " +
                  std::to_string(std::count(outside.begin(), outside.end(), 1)) +
                  " vertices lie outside the cage's bounding box " + format_point(lo) + " – " + format_point(hi) +
                  ", within the box " + format_point(box_lo) + " – " + format_point(box_hi) + "; first: vertex " +
                  std::to_string(v) + " at " + format_point(mesh.positions.col(v)),
              "enlarge the cage so it encloses the whole mesh (check both are in the same units and frame)");
}

/// Orients the surface consistently and counts where it crosses itself, warning about
/// both: what the bake repairs, and what it bakes as it is.
void repair_surface(SurfaceMesh& mesh, const std::string& mesh_name, BakeStats& s) {
  s.repeated_triangles = remove_repeated_triangles(mesh);
  if (s.repeated_triangles > 0) {
    log_warning(mesh_name + ": dropped " + std::to_string(s.repeated_triangles) +
                " triangles that repeat an earlier triangle's corners; " + std::to_string(mesh.triangle_count()) +
                " remain");
  }
  const OrientationRepair orientation = orient_surface(mesh);
  s.flipped_triangles = orientation.flipped();
  if (orientation.flipped_to_agree > 0) {
    log_warning(mesh_name + ": flipped " + std::to_string(orientation.flipped_to_agree) +
                " triangles whose winding disagreed with their neighbours'");
  }
  if (orientation.inside_out_pieces > 0) {
    log_warning(mesh_name + ": turned " + std::to_string(orientation.inside_out_pieces) + " inside-out closed pieces (" +
                std::to_string(orientation.flipped_inside_out) + " triangles) right side out");
  }
  if (orientation.non_orientable > 0) {
    log_warning(mesh_name + ": " + std::to_string(orientation.non_orientable) +
                " pieces cannot be oriented consistently (like a Möbius strip); baked as they are");
  }
  s.self_intersections = count_self_intersections(mesh);
  if (s.self_intersections > 0) {
    log_warning(mesh_name + ": " + std::to_string(s.self_intersections) +
                " pairs of triangles cross each other; baked as they are: where pieces overlap, the solid counts "
                "them once (winding number ≥ ½)");
  }
}

/// Repairs the surface, reports its topology and builds the cage's face table.
void prepare_topology(formats::Bundle& bundle, const std::string& mesh_name, const std::string& cage_name, BakeStats& s) {
  const SurfaceMesh& mesh = bundle.render;
  const TetMesh& cage = bundle.cage;
  const auto start = Clock::now();
  repair_surface(bundle.render, mesh_name, s);
  bundle.embedding.surface_self_intersections = s.self_intersections;
  const SurfaceTopology topology = analyze_topology(mesh);
  s.boundary_edges = topology.boundary_edges;
  s.boundary_loops = topology.boundary_loops;
  s.nonmanifold_edges = topology.nonmanifold_edges;
  if (!topology.closed()) {
    log_warning(mesh_name + ": the surface is not closed (" + std::to_string(topology.boundary_edges) +
                " boundary edges in " + std::to_string(topology.boundary_loops) + " loops, " +
                std::to_string(topology.nonmanifold_edges) +
                " non-manifold edges); inside/outside comes from generalized winding numbers");
  }
  require_inside_cage_bounds(mesh, cage, mesh_name, cage_name);
  bundle.faces = build_cage_faces(cage, cage_name);
  s.faces_s = seconds_since(start);
  log_stage("topology", std::to_string(topology.edges) + " surface edges, " + std::to_string(bundle.faces.face_count()) +
                            " cage faces",
            s.faces_s);
}

/// Every triangle to every tet it touches, exactly (the instances).
TriangleTetPairs assign_instances(formats::Bundle& bundle, const std::string& mesh_name, BakeStats& s) {
  formats::Embedding& e = bundle.embedding;
  const auto start = Clock::now();
  TriangleTetPairs pairs = assign_triangles(bundle.render, bundle.cage, bundle.faces);
  s.candidates = pairs.candidates;
  s.degenerate_triangles = pairs.degenerate_triangles;
  if (pairs.degenerate_triangles > 0) {
    log_warning(mesh_name + ": skipped " + std::to_string(pairs.degenerate_triangles) +
                " degenerate (zero-area) triangles; they draw nothing");
  }
  e.instance_triangle = pairs.triangle;
  e.instance_tet = pairs.tet;
  e.instance_barycentric = std::move(pairs.barycentric);
  s.assign_s = seconds_since(start);
  log_stage("assign", std::to_string(e.instance_count()) + " instances from " + std::to_string(pairs.candidates) +
                          " box-overlap candidates",
            s.assign_s);
  return pairs;
}

/// Each cage node inside or outside the solid (winding numbers), and each tet's class.
void classify_cage(formats::Bundle& bundle, const BakeOptions& options, BakeStats& s) {
  const SurfaceMesh& mesh = bundle.render;
  const TetMesh& cage = bundle.cage;
  formats::Embedding& e = bundle.embedding;
  const auto start = Clock::now();
  const WindingNumberTree winding(mesh, options.winding_accuracy);
  e.node_winding.resize(cage.node_count());
  e.node_inside.resize(cage.node_count());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cage.node_count(), 16), [&](const auto& range) {
    for (std::size_t n = range.begin(); n != range.end(); ++n) {
      e.node_winding[n] = winding.winding_number(cage.rest_positions.col(static_cast<Eigen::Index>(n)));
      e.node_inside[n] = e.node_winding[n] >= 0.5 ? 1 : 0;
    }
  });
  // A tet the surface does not pass through is wholly inside or wholly outside;
  // its centroid decides which (more robust than any one node on an open surface).
  std::vector<std::uint8_t> crossed(cage.tet_count(), 0);
  for (const TetIndex t : e.instance_tet) crossed[t] = 1;
  e.tet_class.resize(cage.tet_count());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cage.tet_count(), 16), [&](const auto& range) {
    for (std::size_t t = range.begin(); t != range.end(); ++t) {
      if (crossed[t]) {
        e.tet_class[t] = formats::TetClass::Crossing;
        continue;
      }
      Vec3 centroid = Vec3::Zero();
      for (int k = 0; k < 4; ++k) centroid += cage.rest_positions.col(cage.tets(k, static_cast<Eigen::Index>(t)));
      e.tet_class[t] = winding.winding_number(centroid / 4.0) >= 0.5 ? formats::TetClass::Inside : formats::TetClass::Outside;
    }
  });
  s.classify_s = seconds_since(start);
  {
    std::size_t inside_nodes = 0, by_class[3] = {0, 0, 0};
    for (const auto flag : e.node_inside) inside_nodes += flag;
    for (const auto cls : e.tet_class) ++by_class[static_cast<int>(cls)];
    log_stage("classify",
              std::to_string(inside_nodes) + " of " + std::to_string(cage.node_count()) + " nodes inside; tets: " +
                  std::to_string(by_class[2]) + " crossing, " + std::to_string(by_class[1]) + " inside, " +
                  std::to_string(by_class[0]) + " outside",
              s.classify_s);
  }
}

/// The exact segments where the surface crosses each cage face.
void contour_stage(formats::Bundle& bundle, const TriangleTetPairs& pairs, BakeStats& s) {
  formats::Embedding& e = bundle.embedding;
  const auto start = Clock::now();
  FaceContours contours = extract_contours(bundle.render, bundle.cage, bundle.faces, pairs);
  s.coplanar_pairs = contours.coplanar_pairs;
  e.contour_offsets = std::move(contours.offsets);
  e.contour_points = std::move(contours.points);
  e.contour_triangle = std::move(contours.triangle);
  e.contour_feature = std::move(contours.features);
  e.face_degenerate = std::move(contours.degenerate_faces);
  s.contours_s = seconds_since(start);
  log_stage("contours", std::to_string(e.segment_count()) + " segments on the cage faces", s.contours_s);
}

/// Stage 2: a wall tile for every face the surface crosses.
void wall_stage(formats::Bundle& bundle, const FaceRegions& regions, const BakeOptions& options, BakeStats& s) {
  const auto start = Clock::now();
  bundle.walls = bake_walls(bundle, regions, options.wall);
  s.walls_s = seconds_since(start);
  log_stage("walls",
            std::to_string(bundle.walls->tile_count()) + " tiles of " + std::to_string(options.wall.resolution) + "² texels",
            s.walls_s);
}

/// Stage 2: collision spheres, mass fractions and centres of mass per tet.
void collision_stage(formats::Bundle& bundle, const FaceRegions& regions, const BakeOptions& options, BakeStats& s) {
  const auto start = Clock::now();
  // Sphere centres only need the side of the surface they are on, and there are many
  // of them: a coarser winding-number tree (β = 2, about 3× faster per query, error
  // ≤ 0.03 on the sample bunny) is plenty away from the surface itself.
  const WindingNumberTree sampling(bundle.render, 2.0);
  bundle.collision = bake_collision(bundle, regions, sampling, options.spheres, &s.collision);
  s.collision_s = seconds_since(start);
  char radius[32];
  std::snprintf(radius, sizeof radius, "%.4g", bundle.collision->target_radius);
  log_stage("collision",
            std::to_string(bundle.collision->sphere_tet.size()) + " spheres (target radius " + radius + "; " +
                std::to_string(s.collision.surface) + " on the surface, " + std::to_string(s.collision.culled) +
                " surrounded ones culled, " + std::to_string(s.collision.near_surface) + " at the surface dropped; " + std::to_string(s.collision.tets_bare) +
                " tets with solid but no sphere, given one by the player when fracture exposes them; " +
                std::to_string(s.collision.reserve) + " reserve spheres for render vertices, given when fracture parts their tets from the spheres that cover those vertices)",
            s.collision_s);
}

}  // namespace

std::string generator_string() { return std::string(kGeneratorName) + " " + FISSURE_VERSION; }

std::string BakeOptions::to_json() const {
  JsonWriter j;
  j.begin_object();
  j.key("weld").value(import.weld);
  j.key("winding_accuracy").value(winding_accuracy);
  j.key("coverage_tolerance").value(coverage_tolerance);
  j.key("stages").begin_array().value("embedding");
  if (walls) j.value("walls");
  if (collision) j.value("collision");
  j.end_array();
  if (walls) {
    j.key("wall_resolution").value(static_cast<std::int64_t>(wall.resolution));
    j.key("wall_sdf_range_texels").value(wall.sdf_range_texels);
    j.key("wall_depth_divisor").value(static_cast<std::int64_t>(wall.depth_divisor));
    j.key("wall_detail_resolution").value(static_cast<std::int64_t>(wall.detail_resolution));
    j.key("wall_detail_seed").value(static_cast<std::uint64_t>(wall.detail_seed));
  }
  if (collision) {
    j.key("sphere_radius").value(spheres.radius);
    j.key("sphere_version").value(static_cast<std::int64_t>(kSphereVersion));
    j.key("surface_spacing").value(spheres.surface_spacing);
  }
  if (cage.enabled()) {
    j.key("cage_method").value(cage.method);
    j.key("cage_tets").value(static_cast<std::uint64_t>(cage.tets));
    j.key("cage_tolerance").value(cage.tolerance);
    j.key("cage_version").value(kAutoCageVersion);
    if (cage.keep_holes) j.key("cage_keep_holes").value(true);  // absent otherwise: older bundles stay current
  }
  j.end_object();
  return j.str();
}

formats::Bundle embed(const SurfaceMesh& input_mesh, const TetMesh& cage, const BakeOptions& options,
                      const std::string& mesh_name, const std::string& cage_name, BakeStats* stats) {
  BakeStats local;
  BakeStats& s = stats ? *stats : local;
  if (input_mesh.triangle_count() == 0) throw Error(mesh_name + ": the mesh has no triangles");
  // Bad stage options fail before any work.
  if (options.walls) validate(options.wall);
  if (options.collision) {
    validate(options.spheres);
    check_collision_work(input_mesh, cage, options.spheres);
  }

  formats::Bundle bundle;
  bundle.render = input_mesh;
  bundle.cage = cage;
  prepare_topology(bundle, mesh_name, cage_name, s);
  const TriangleTetPairs pairs = assign_instances(bundle, mesh_name, s);
  auto start = Clock::now();
  require_coverage(bundle.render, cage, bundle.embedding, options.coverage_tolerance, mesh_name, cage_name);
  s.coverage_s = seconds_since(start);
  log_stage("coverage", "every triangle's area is inside the cage", s.coverage_s);

  classify_cage(bundle, options, s);
  contour_stage(bundle, pairs, s);

  if (!options.walls && !options.collision) return bundle;
  start = Clock::now();
  const FaceRegions regions = build_face_regions(bundle);
  s.regions_s = seconds_since(start);
  s.inconsistent_faces = regions.inconsistent_faces;
  if (regions.inconsistent_faces > 0) {
    log_warning(mesh_name + ": on " + std::to_string(regions.inconsistent_faces) +
                " cage faces the contours and the node classes disagree (an open or self-intersecting surface); "
                "their walls follow the contours");
  }
  if (options.walls) wall_stage(bundle, regions, options, s);
  if (options.collision) collision_stage(bundle, regions, options, s);
  return bundle;
}

formats::Bundle bake_files(const std::filesystem::path& mesh_path, const std::filesystem::path& cage_path,
                           const BakeOptions& options, BakeStats* stats) {
  BakeStats local;
  BakeStats& s = stats ? *stats : local;
  const auto start = Clock::now();
  const ImportedMesh imported = import_render_mesh(mesh_path, options.import);
  const formats::CageFile cage = formats::read_cage(cage_path);
  s.import_s = seconds_since(start);
  log_stage("read", mesh_path.filename().string() + ": " + std::to_string(imported.mesh.vertex_count()) + " vertices, " +
                        std::to_string(imported.mesh.triangle_count()) + " triangles; " + cage_path.filename().string() +
                        ": " + std::to_string(cage.mesh.node_count()) + " nodes, " + std::to_string(cage.mesh.tet_count()) +
                        " tets",
            s.import_s);

  formats::Bundle bundle = embed(imported.mesh, cage.mesh, options, mesh_path.string(), cage_path.string(), &s);
  bundle.metadata.generator = generator_string();
  bundle.metadata.bake_options = options.to_json();
  // Where they were (BundleInput::path) depends on the bundle's place: the CLI records it.
  bundle.metadata.inputs.push_back({"mesh", mesh_path.filename().string(), sha256_hex({mesh_path}), ""});
  const bool pair = cage.element_path != cage.node_path;
  bundle.metadata.inputs.push_back(
      {"cage",
       pair ? cage.node_path.filename().string() + "+" + cage.element_path.filename().string()
            : cage.node_path.filename().string(),
       pair ? sha256_hex({cage.node_path, cage.element_path}) : sha256_hex({cage.node_path}), ""});
  return bundle;
}

formats::Bundle bake_with_auto_cage(const std::filesystem::path& mesh_path, const BakeOptions& options,
                                    BakeStats* stats) {
  BakeStats local;
  BakeStats& s = stats ? *stats : local;
  validate(options.cage);
  const auto start = Clock::now();
  const ImportedMesh imported = import_render_mesh(mesh_path, options.import);
  s.import_s = seconds_since(start);
  log_stage("read", mesh_path.filename().string() + ": " + std::to_string(imported.mesh.vertex_count()) + " vertices, " +
                        std::to_string(imported.mesh.triangle_count()) + " triangles",
            s.import_s);
  const AutoCage cage = make_cage(imported.mesh, options.cage, mesh_path.string(), options.winding_accuracy);
  const std::string cage_name = "the automatic " + cage.method + " cage";
  formats::Bundle bundle = embed(imported.mesh, cage.mesh, options, mesh_path.string(), cage_name, &s);
  bundle.metadata.generator = generator_string();
  bundle.metadata.bake_options = options.to_json();
  // The cage is no file: the mesh, the options and the version say all that made it.
  bundle.metadata.inputs.push_back({"mesh", mesh_path.filename().string(), sha256_hex({mesh_path}), ""});
  return bundle;
}

void check_cage_covers(const SurfaceMesh& mesh, const TetMesh& cage, const std::string& mesh_name,
                       const std::string& cage_name) {
  require_inside_cage_bounds(mesh, cage, mesh_name, cage_name);
  const CageFaces faces = build_cage_faces(cage, cage_name);
  const TriangleTetPairs pairs = assign_triangles(mesh, cage, faces);
  formats::Embedding embedding;
  embedding.instance_triangle = pairs.triangle;
  embedding.instance_tet = pairs.tet;
  embedding.instance_barycentric = pairs.barycentric;
  require_coverage(mesh, cage, embedding, BakeOptions{}.coverage_tolerance, mesh_name, cage_name);
}

}  // namespace fissure::bake
