// Bake benchmarks: thesis Table II replication counts, and bake time and peak memory
// as triangles and tets grow. Prints Markdown tables for BENCHMARKS.md.
//
//   fissure_bake_bench [--data DIR] [--large DIR] [--max-subdivisions N] [--threads N]
//
// DIR defaults to the repository's data/; --large names a folder holding
// meshes/bunny-full.obj (the shared data set), which the large cases need.
#include <malloc.h>
#include <sys/wait.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/intersections.h>

#include "bake/bake.h"
#include "bake/exact_embedding.h"
#include "bake/replication.h"
#include "common/error.h"
#include "common/log.h"
#include "formats/cage_io.h"
#include "tests/support/procedural.h"

namespace {

using namespace fissure;
namespace fs = std::filesystem;

// Thesis Table II (Clack 2012, p. 51): tets, 1×…7×, total.
struct ThesisRow {
  int tets;
  int counts[7];
  int total;
};
constexpr ThesisRow kThesis[] = {
    {10, {4315, 661, 18, 6, 0, 0, 0}, 5715},     {20, {3871, 1049, 62, 14, 4, 0, 0}, 6231},
    {31, {3575, 1275, 109, 32, 5, 4, 0}, 6629},  {41, {3353, 1467, 137, 29, 6, 6, 0}, 6880},
    {50, {3358, 1445, 144, 37, 7, 5, 2}, 6907},  {60, {3258, 1532, 145, 39, 14, 10, 2}, 7057},
    {72, {3040, 1713, 174, 42, 16, 13, 2}, 7328}, {82, {2972, 1733, 204, 55, 20, 10, 6}, 7472},
    {91, {2972, 1733, 204, 55, 20, 10, 6}, 7472}, {100, {2856, 1848, 209, 51, 16, 17, 3}, 7586},
};

void print_table_two(const fs::path& data) {
  std::vector<std::string> cages;
  for (const int n : {10, 20, 29, 38, 51, 58, 68, 80, 89, 100}) {
    cages.push_back((data / "cages" / ("bunny-5k-cage-" + std::to_string(n) + ".node")).string());
  }
  const auto rows = bake::replication_study((data / "meshes" / "bunny-5k.obj").string(), cages, {});
  std::printf("\n### Replication (thesis Table II), bunny-5k\n\n");
  std::printf("| tets (ours / thesis) | 1× | 2× | 3× | 4× | 5× | 6× | 7× | 8+× | total (ours / thesis) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& r = rows[i];
    const ThesisRow& t = kThesis[i];
    std::printf("| %zu / %d |", r.tets, t.tets);
    for (int k = 1; k <= 7; ++k) std::printf(" %zu / %d |", r.counts[static_cast<std::size_t>(k)], t.counts[k - 1]);
    std::printf(" %zu / – | %zu / %d |\n", r.counts[8], r.instances, t.total);
  }
}

/// The thesis's assignment (III.B): every triangle against every tet, here with
/// CGAL's exact do_intersect, timed against the bake's box-culled assignment.
void print_all_pairs_baseline(const fs::path& data) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  const SurfaceMesh mesh = bake::import_render_mesh(data / "meshes" / "bunny-5k.obj").mesh;
  std::printf("\n### Assignment: box-culled (ours) vs all pairs (thesis III.B), bunny-5k, same run\n\n");
  std::printf("| cage tets | all-pairs tests | all-pairs s | ours s | speed-up | same instances |\n|---|---|---|---|---|---|\n");
  for (const char* name : {"bunny-5k-cage-100.node", "bunny-5k-cage-987.node"}) {
    const TetMesh cage = formats::read_cage(data / "cages" / name).mesh;
    auto point = [](const Matrix3Xd& m, Index i) { return K::Point_3(m(0, i), m(1, i), m(2, i)); };
    auto start = std::chrono::steady_clock::now();
    std::size_t hits = 0;
    for (Index t = 0; t < mesh.triangle_count(); ++t) {
      const K::Triangle_3 tri(point(mesh.positions, mesh.triangles(0, t)), point(mesh.positions, mesh.triangles(1, t)),
                              point(mesh.positions, mesh.triangles(2, t)));
      for (Index k = 0; k < cage.tet_count(); ++k) {
        const K::Tetrahedron_3 tet(point(cage.rest_positions, cage.tets(0, k)), point(cage.rest_positions, cage.tets(1, k)),
                                   point(cage.rest_positions, cage.tets(2, k)), point(cage.rest_positions, cage.tets(3, k)));
        hits += CGAL::do_intersect(tri, tet) ? 1 : 0;
      }
    }
    const double all_pairs_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    start = std::chrono::steady_clock::now();
    const bake::TriangleTetPairs pairs = bake::assign_triangles(mesh, cage, build_cage_faces(cage, name));
    const double ours_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("| %zu | %zu | %.3f | %.4f | %.0f× | %s |\n", cage.tet_count(), mesh.triangle_count() * cage.tet_count(),
                all_pairs_s, ours_s, all_pairs_s / ours_s,
                hits == pairs.triangle.size() + pairs.coplanar_dropped ? "yes" : "NO");
  }
}

struct CaseResult {
  double total_s = 0, import_s = 0, assign_s = 0, coverage_s = 0, classify_s = 0, contours_s = 0;
  double regions_s = 0, walls_s = 0, collision_s = 0;
  std::size_t tiles = 0, spheres = 0;
  std::size_t triangles = 0, tets = 0, instances = 0, segments = 0;
  long peak_kib = 0;
  long baseline_kib = 0;  ///< resident when the child started (meshes the harness holds)
};

/// A field of /proc/self/status in KiB (VmRSS, VmHWM), or -1.
long status_kib(const char* field) {
  long value = -1;
  if (FILE* f = std::fopen("/proc/self/status", "r")) {
    char line[256];
    const std::size_t length = std::strlen(field);
    while (std::fgets(line, sizeof line, f) != nullptr) {
      if (std::strncmp(line, field, length) == 0 && line[length] == ':') value = std::atol(line + length + 1);
    }
    std::fclose(f);
  }
  return value;
}

/// Resets the process's peak resident set (VmHWM) to its current size (Linux ≥ 4.0),
/// so the peak measured afterwards belongs to the work that follows, not to the
/// harness that loaded the meshes before forking.
void reset_peak_rss() {
  if (FILE* f = std::fopen("/proc/self/clear_refs", "w")) {
    std::fputs("5", f);
    std::fclose(f);
  }
}

/// Runs one bake in a child process so its peak memory is its own.
bool run_case(const SurfaceMesh& mesh, const fs::path& cage_path, CaseResult& out) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) return false;
  const pid_t child = fork();
  if (child == 0) {
    close(pipe_fds[0]);
    CaseResult r;
    malloc_trim(0);  // hand the harness's freed heap back, or the bake would reuse it unseen
    reset_peak_rss();
    r.baseline_kib = status_kib("VmRSS");
    const auto start = std::chrono::steady_clock::now();
    const formats::CageFile cage = formats::read_cage(cage_path);
    bake::BakeStats stats;
    const formats::Bundle bundle = bake::embed(mesh, cage.mesh, bake::BakeOptions{}, "mesh", cage_path.string(), &stats);
    r.total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.assign_s = stats.assign_s;
    r.coverage_s = stats.coverage_s;
    r.classify_s = stats.classify_s;
    r.contours_s = stats.contours_s;
    r.regions_s = stats.regions_s;
    r.walls_s = stats.walls_s;
    r.collision_s = stats.collision_s;
    r.tiles = bundle.walls ? bundle.walls->tile_count() : 0;
    r.spheres = bundle.collision ? bundle.collision->sphere_tet.size() : 0;
    r.triangles = mesh.triangle_count();
    r.tets = cage.mesh.tet_count();
    r.instances = bundle.embedding.instance_count();
    r.segments = bundle.embedding.segment_count();
    r.peak_kib = status_kib("VmHWM");
    const ssize_t written = write(pipe_fds[1], &r, sizeof r);
    _exit(written == static_cast<ssize_t>(sizeof r) ? 0 : 1);
  }
  close(pipe_fds[1]);
  const ssize_t got = read(pipe_fds[0], &out, sizeof out);
  close(pipe_fds[0]);
  int status = 0;
  waitpid(child, &status, 0);
  return got == static_cast<ssize_t>(sizeof out) && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

}  // namespace

int main(int argc, char** argv) {
  fs::path data = FISSURE_BENCH_DATA_DIR;
  fs::path large;
  int max_subdivisions = 2;
  int threads = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "error: %s needs a value\n", arg.c_str());
        std::exit(1);
      }
      return argv[++i];
    };
    if (arg == "--data") data = value();
    else if (arg == "--large") large = value();
    else if (arg == "--max-subdivisions") max_subdivisions = std::stoi(value());
    else if (arg == "--threads") threads = std::stoi(value());
    else {
      std::fprintf(stderr, "usage: %s [--data DIR] [--large DIR] [--max-subdivisions N] [--threads N]\n", argv[0]);
      return arg == "--help" ? 0 : 1;
    }
  }
  set_log_level(LogLevel::Warning);
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0) {
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  }

  try {

    struct MeshCase {
      std::string name;
      SurfaceMesh mesh;
    };
    std::vector<MeshCase> meshes;
    meshes.push_back({"bunny-5k", bake::import_render_mesh(data / "meshes" / "bunny-5k.obj").mesh});
    if (!large.empty()) {
      SurfaceMesh full = bake::import_render_mesh(large / "meshes" / "bunny-full.obj").mesh;
      meshes.push_back({"bunny-full", full});
      for (int s = 1; s <= max_subdivisions; ++s) {
        full = testing::subdivide(full);
        meshes.push_back({"bunny-full ×4^" + std::to_string(s), full});
      }
    }
    std::printf("\n### Bake time and peak memory, all stages (threads: %s; walls 64², default sphere radius)\n\n",
                threads > 0 ? std::to_string(threads).c_str() : "all");
    std::printf("| mesh | triangles | tets | instances | assign s | coverage s | classify s | contours s | regions s | "
                "walls s (tiles) | collision s (spheres) | total s | µs per (triangle+tet) | peak MiB above baseline |\n"
                "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (const MeshCase& m : meshes) {
      for (const char* cage : {"bunny-5k-cage-987.node", "bunny-5k-cage-10024.node"}) {
        CaseResult r;
        if (!run_case(m.mesh, data / "cages" / cage, r)) {
          std::printf("| %s | %zu | %s | failed | | | | | | | | | | |\n", m.name.c_str(), m.mesh.triangle_count(), cage);
          continue;
        }
        std::printf("| %s | %zu | %zu | %zu | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f (%zu) | %.3f (%zu) | %.3f | %.2f | %.0f |\n",
                    m.name.c_str(), r.triangles, r.tets, r.instances, r.assign_s, r.coverage_s, r.classify_s,
                    r.contours_s, r.regions_s, r.walls_s, r.tiles, r.collision_s, r.spheres, r.total_s,
                    1e6 * r.total_s / static_cast<double>(r.triangles + r.tets),
                    static_cast<double>(r.peak_kib - r.baseline_kib) / 1024.0);
        std::fflush(stdout);
      }
    }
    // After the forked cases: a child forked once TBB's workers exist in the parent
    // would run its parallel loops on one thread.
    print_table_two(data);
    print_all_pairs_baseline(data);
  } catch (const Error& e) {
    std::fputs(format_error(e).c_str(), stderr);
    return 1;
  }
  return 0;
}
