// Trade-study sweeps for bake stage 2 (walls and collision spheres): what each knob
// costs and what it buys. Prints Markdown tables for BENCHMARKS.md.
//
//   fissure_stage2_sweep [--mesh M] [--cage C] [--threads N] [--csv DIR] [--quick]
//
// Defaults: the repository's bunny-5k in its 987-tet cage. --csv also writes the
// figures to DIR/walls.csv and DIR/spheres-bake.csv (pipelines/tradeoffs plots them);
// --quick sweeps two points per knob, for CI.
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "bake/bake.h"
#include "common/error.h"
#include "common/log.h"
#include "formats/bundle_checks.h"
#include "formats/bundle_inspect.h"
#include "formats/cage_io.h"
#include "tests/support/csv_table.h"

namespace {

using namespace fissure;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::uint64_t stored_bytes(const fs::path& file, const std::string& group) {
  std::uint64_t total = 0;
  for (const auto& d : formats::summarize_bundle(file).datasets) {
    if (d.path.rfind("/" + group + "/", 0) == 0) total += d.stored_bytes;
  }
  return total;
}

struct Plan {
  std::vector<std::uint32_t> wall_resolutions{8, 16, 32, 64, 128, 256};
  std::vector<double> radius_scales{4.0, 2.0, 1.0, 0.5, 0.25};
  fs::path csv;  ///< empty: Markdown only

  static Plan quick() { return {{8, 32, 64}, {1.0, 0.5}, {}}; }
};

void wall_sweep(const SurfaceMesh& mesh, const TetMesh& cage, const fs::path& scratch, const Plan& plan) {
  std::printf("\n### Wall resolution: coverage error, time, size\n\n");
  std::printf("Coverage error: Σ over crossing faces of |tile texel count × texel area − exact inside area|, relative to "
              "the total inside area of those faces (texel centres inside the face only).\n\n");
  std::printf("| resolution | tiles | coverage error | walls stage s | /walls stored MiB | ratio to 64² time |\n|---|---|---|---|---|---|\n");
  double baseline_s = 0.0;
  struct Row {
    std::uint32_t res;
    std::size_t tiles;
    double error, seconds, mib;
  };
  std::vector<Row> rows;
  for (const std::uint32_t res : plan.wall_resolutions) {
    bake::BakeOptions options;
    options.collision = false;
    options.wall.resolution = res;
    bake::BakeStats stats;
    const formats::Bundle b = bake::embed(mesh, cage, options, "mesh", "cage", &stats);
    double error = 0.0, exact = 0.0;
    for (FaceIndex f = 0; f < b.faces.face_count(); ++f) {
      if (b.walls->face_tile[f] == kInvalidIndex) continue;
      error += std::abs(formats::tile_inside_area(*b.walls, f, face_area(b.cage, b.faces, f)) - b.walls->face_inside_area[f]);
      exact += b.walls->face_inside_area[f];
    }
    const fs::path file = scratch / ("walls-" + std::to_string(res) + ".h5");
    formats::write_bundle(file, b);
    rows.push_back({res, b.walls->tile_count(), error / exact, stats.walls_s + stats.regions_s,
                    static_cast<double>(stored_bytes(file, "walls")) / (1024.0 * 1024.0)});
    if (res == 64) baseline_s = stats.walls_s + stats.regions_s;
    fs::remove(file);
  }
  testing::CsvTable csv(plan.csv, "walls", {"resolution", "tiles", "coverage_error", "walls_stage_s", "walls_stored_mib"});
  for (const Row& r : rows) {
    std::printf("| %u² | %zu | %.2e | %.3f | %.2f | %.2f× |\n", r.res, r.tiles, r.error, r.seconds, r.mib, r.seconds / baseline_s);
    csv.row({r.res, r.tiles, r.error, r.seconds, r.mib});
  }
}

/// Distance from each surface sample to the nearest sphere's surface (negative inside
/// a sphere), through a uniform grid of sphere centres.
struct SphereGrid {
  double cell;
  std::unordered_map<std::int64_t, std::vector<std::size_t>> bins;
  std::vector<Vec3> centres;
  std::vector<double> radii;
  static std::int64_t key(std::int64_t i, std::int64_t j, std::int64_t k) {
    return (i * 73856093) ^ (j * 19349663) ^ (k * 83492791);
  }
  double nearest_gap(const Vec3& p) const {
    const auto ci = static_cast<std::int64_t>(std::floor(p.x() / cell));
    const auto cj = static_cast<std::int64_t>(std::floor(p.y() / cell));
    const auto ck = static_cast<std::int64_t>(std::floor(p.z() / cell));
    double best = std::numeric_limits<double>::infinity();
    for (std::int64_t ring = 1; ring < 64; ++ring) {
      for (std::int64_t i = ci - ring; i <= ci + ring; ++i) {
        for (std::int64_t j = cj - ring; j <= cj + ring; ++j) {
          for (std::int64_t k = ck - ring; k <= ck + ring; ++k) {
            const auto it = bins.find(key(i, j, k));
            if (it == bins.end()) continue;
            for (const std::size_t s : it->second) best = std::min(best, (p - centres[s]).norm() - radii[s]);
          }
        }
      }
      if (best <= static_cast<double>(ring - 1) * cell) break;  // nothing farther out can be nearer
    }
    return best;
  }
};

void sphere_sweep(const SurfaceMesh& mesh, const TetMesh& cage, const Plan& plan) {
  const double base = bake::default_sphere_radius(mesh);
  std::printf("\n### Collision sphere radius: count, surface coverage, time\n\n");
  std::printf("Gap: distance from each render vertex to the nearest sphere surface (negative: inside a sphere), "
              "in units of the default radius %.4g.\n\n", base);
  std::printf("| radius / default | spheres | culled | on the surface | mean gap | max gap | collision stage s |\n|---|---|---|---|---|---|---|\n");
  testing::CsvTable csv(plan.csv, "spheres-bake", {"radius_over_default", "default_radius_m", "spheres", "culled", "surface_spheres",
                                                  "mean_gap_over_default", "max_gap_over_default", "collision_stage_s"});
  for (const double scale : plan.radius_scales) {
    bake::BakeOptions options;
    options.walls = false;
    options.spheres.radius = scale * base;
    bake::BakeStats stats;
    const formats::Bundle b = bake::embed(mesh, cage, options, "mesh", "cage", &stats);
    SphereGrid grid;
    grid.cell = 2.0 * scale * base;
    for (std::size_t s = 0; s < b.collision->sphere_tet.size(); ++s) {
      Eigen::Matrix<double, 3, 4> nodes;
      for (int i = 0; i < 4; ++i) nodes.col(i) = b.cage.rest_positions.col(b.cage.tets(i, b.collision->sphere_tet[s]));
      const Vec3 c = nodes * b.collision->sphere_barycentric[s];
      grid.centres.push_back(c);
      grid.radii.push_back(b.collision->sphere_radius[s]);
      grid.bins[SphereGrid::key(static_cast<std::int64_t>(std::floor(c.x() / grid.cell)),
                                static_cast<std::int64_t>(std::floor(c.y() / grid.cell)),
                                static_cast<std::int64_t>(std::floor(c.z() / grid.cell)))]
          .push_back(s);
    }
    double sum = 0.0, worst = -std::numeric_limits<double>::infinity();
    for (Index v = 0; v < mesh.vertex_count(); ++v) {
      const double gap = grid.nearest_gap(mesh.positions.col(v));
      sum += gap;
      worst = std::max(worst, gap);
    }
    std::printf("| %.2f | %zu | %zu | %zu | %.3f | %.3f | %.3f |\n", scale, b.collision->sphere_tet.size(),
                stats.collision.culled, stats.collision.surface, sum / static_cast<double>(mesh.vertex_count()) / base,
                worst / base, stats.collision_s);
    csv.row({scale, base, b.collision->sphere_tet.size(), stats.collision.culled, stats.collision.surface,
             sum / static_cast<double>(mesh.vertex_count()) / base, worst / base, stats.collision_s});
  }
}

}  // namespace

int main(int argc, char** argv) {
  fs::path mesh_path = fs::path(FISSURE_BENCH_DATA_DIR) / "meshes" / "bunny-5k.obj";
  fs::path cage_path = fs::path(FISSURE_BENCH_DATA_DIR) / "cages" / "bunny-5k-cage-987.node";
  int threads = 0;
  Plan plan;
  fs::path csv;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--quick") {
      plan = Plan::quick();
      continue;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "error: %s needs a value\nusage: %s [--mesh M] [--cage C] [--threads N] [--csv DIR] [--quick]\n",
                   arg.c_str(), argv[0]);
      return 1;
    }
    const std::string value = argv[++i];
    if (arg == "--mesh") mesh_path = value;
    else if (arg == "--cage") cage_path = value;
    else if (arg == "--threads") threads = std::stoi(value);
    else if (arg == "--csv") csv = value;
    else {
      std::fprintf(stderr, "error: unknown option %s\nusage: %s [--mesh M] [--cage C] [--threads N] [--csv DIR] [--quick]\n",
                   arg.c_str(), argv[0]);
      return 1;
    }
  }
  plan.csv = csv;
  set_log_level(LogLevel::Quiet);
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0) {
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  }
  try {
    const SurfaceMesh mesh = bake::import_render_mesh(mesh_path).mesh;
    const TetMesh cage = formats::read_cage(cage_path).mesh;
    std::printf("## %s in %s (%zu triangles, %zu tets)\n", mesh_path.filename().c_str(), cage_path.filename().c_str(),
                mesh.triangle_count(), cage.tet_count());
    const fs::path scratch = fs::temp_directory_path() / ("fissure-sweep-" + std::to_string(::getpid()));
    fs::create_directories(scratch);
    wall_sweep(mesh, cage, scratch, plan);
    sphere_sweep(mesh, cage, plan);
    fs::remove_all(scratch);
  } catch (const Error& e) {
    std::fputs(format_error(e).c_str(), stderr);
    return 1;
  }
  return 0;
}
