// The cost of drawing an embedded mesh (thesis Figs. 21–22, issue 14): per mesh and cage,
// the embedded draw against a plain draw of the same mesh mapped on the CPU, the bytes
// uploaded per frame, and the physics step, which must not grow with the triangles.
//
// usage: fissure_render_bench [--size WxH] [--frames N] [--backend osmesa|egl]
//                             [--subdivisions K] [--shared DIR] [--cage-sweep N,N,…]
//                             [--no-tessellation] [--csv DIR]
//   --subdivisions K  also the bunny split 1→4 up to K times (default 2: 5k, 20k, 80k triangles)
//   --shared DIR      also the 10,024-tet cage (the name is older than the cage's copy in data/)
//   --cage-sweep LIST also the bunny-5k alone in each data/cages/bunny-5k-cage-N named
//                     (thesis Fig. 21 and Table II: replication and cost against tets)
//   --csv DIR         also write every row to DIR/draw.csv (pipelines/tradeoffs plots it)
// Each cage in the first table is drawn with every mesh (thesis Fig. 22: physics flat with
// triangles). Then the cost of the ground, sky and shadows (issue 44) on the first mesh
// and cage. Then, unless --no-tessellation, the cost of tessellated relief against its
// level cap (every tet apart, every face open: the bunny-5k in the 987-tet cage fully
// shattered).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "bake/bake.h"
#include "bake/mesh_import.h"
#include "common/error.h"
#include "formats/cage_io.h"
#include "player/app/frame_output.h"
#include "player/app/scene_view.h"
#include "player/render/context.h"
#include "tests/support/csv_table.h"
#include "tests/support/mapped_mesh.h"
#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"

namespace {

using namespace fissure;
using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

struct Options {
  int width = 1280, height = 720, frames = 20, subdivisions = 2;
  render::Backend backend = render::Backend::OSMesa;
  std::filesystem::path shared, csv;
  std::vector<std::string> cage_sweep;  ///< tet counts naming data/cages/bunny-5k-cage-N
  bool tessellation = true;
};

constexpr const char* kUsage =
    "usage: fissure_render_bench [--size WxH] [--frames N] [--backend osmesa|egl] [--subdivisions K] [--shared DIR] "
    "[--cage-sweep N,N,...] [--no-tessellation] [--csv DIR]";

std::vector<std::string> split_list(const std::string& list) {
  std::vector<std::string> items;
  std::size_t from = 0;
  while (from <= list.size()) {
    const std::size_t comma = std::min(list.find(',', from), list.size());
    if (comma > from) items.push_back(list.substr(from, comma - from));
    from = comma + 1;
  }
  return items;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--size" && has_value) {
      std::tie(o.width, o.height) = player::parse_size(argv[++i]);
    } else if (arg == "--frames" && has_value) {
      o.frames = std::max(1, std::stoi(argv[++i]));
    } else if (arg == "--backend" && has_value) {
      o.backend = render::parse_backend(argv[++i]);
    } else if (arg == "--subdivisions" && has_value) {
      o.subdivisions = std::clamp(std::stoi(argv[++i]), 0, 4);
    } else if (arg == "--shared" && has_value) {
      o.shared = argv[++i];
    } else if (arg == "--cage-sweep" && has_value) {
      o.cage_sweep = split_list(argv[++i]);
    } else if (arg == "--csv" && has_value) {
      o.csv = argv[++i];
    } else if (arg == "--no-tessellation") {
      o.tessellation = false;
    } else {
      throw Error("unknown argument " + arg, kUsage);
    }
  }
  return o;
}

struct Row {
  std::size_t triangles, tets, instances;
  double bake_s, step_ms, embedded_ms, plain_ms;
  std::size_t upload_bytes;
};

Row measure(const SurfaceMesh& mesh, const TetMesh& cage, const Options& o, render::Renderer& renderer) {
  Row row{mesh.triangle_count(), cage.tet_count(), 0, 0, 0, 0, 0, 0};
  bake::BakeOptions bake_options;
  bake_options.collision = false;
  auto start = Clock::now();
  const formats::Bundle bundle = bake::embed(mesh, cage, bake_options, "mesh", "cage");
  row.bake_s = std::chrono::duration<double>(Clock::now() - start).count();
  row.instances = bundle.embedding.instance_count();
  sim::BodyDescription body = testing::describe("body", cage, sim::Material{.density = 1000, .youngs_modulus = 1e5});
  sim::WorldSettings settings;
  settings.collisions = false;
  settings.step.solver = sim::LinearSolver::ConjugateGradient;
  settings.step.tolerance = 1e-4;
  sim::World world({body}, {}, {}, settings);
  std::vector<double> steps, embedded, plain;
  for (int i = 0; i < 20; ++i) steps.push_back(1e3 * world.step().total);
  row.step_ms = median(steps);

  const std::vector<player::BodyAssets> assets{{"mesh.h5", bundle, 1.0, {}, {}}};
  player::SceneView view(world, assets, renderer);
  std::vector<std::uint8_t> pixels;
  for (int f = 0; f <= o.frames; ++f) {
    view.update(world);
    renderer.render(pixels);
    if (f > 0) embedded.push_back(renderer.last_stats().draw_ms);  // the first frame uploads the static buffers
  }
  row.upload_bytes = renderer.last_stats().upload_bytes;
  row.embedded_ms = median(embedded);
  renderer.set_body_visible(0, false);
  const sim::ImplicitIntegrator& integrator = world.bodies()[0].integrator();
  const std::size_t plain_mesh = renderer.add_plain(testing::mapped_mesh(bundle, integrator.positions(), integrator.elasticity().tets()));
  for (int f = 0; f <= o.frames; ++f) {
    renderer.render(pixels);
    if (f > 0) plain.push_back(renderer.last_stats().draw_ms);
  }
  renderer.set_visible(plain_mesh, false);
  row.plain_ms = median(plain);
  return row;
}

/// The cost of tessellated relief against its level cap, in the worst case: every tet
/// its own fragment, shrunk to 80% about its centroid, every face open, so every wall
/// the bake knows is on screen (inside faces with relief, crossing faces flat).
void measure_tessellation(const SurfaceMesh& mesh, const TetMesh& cage, const Options& o) {
  bake::BakeOptions bake_options;
  bake_options.collision = false;
  const formats::Bundle bundle = bake::embed(mesh, cage, bake_options, "mesh", "cage");
  sim::WorldSettings settings;
  settings.collisions = false;
  const sim::World world({testing::describe("body", cage, sim::Material{})}, {}, {}, settings);
  render::Renderer renderer(o.width, o.height);
  renderer.add_body(player::embedded_mesh(bundle, world.bodies()[0].integrator(), 1.0));
  std::vector<float> positions;
  std::vector<std::uint32_t> tets;
  Eigen::AlignedBox3f box;
  for (TetIndex t = 0; t < cage.tet_count(); ++t) {
    Vec3 centre = Vec3::Zero();
    for (int i = 0; i < 4; ++i) centre += 0.25 * cage.rest_positions.col(cage.tets(i, t));
    for (int i = 0; i < 4; ++i) {
      const Vec3 x = centre + 0.8 * (cage.rest_positions.col(cage.tets(i, t)) - centre);
      positions.insert(positions.end(), {float(x.x()), float(x.y()), float(x.z())});
      tets.push_back(4 * t + static_cast<std::uint32_t>(i));
      box.extend(x.cast<float>());
    }
  }
  const std::vector<std::uint8_t> faces(4 * cage.tet_count(), 2);
  renderer.set_pose(0, {positions, tets, faces, {}, 1});
  renderer.set_camera(render::frame_box(box, render::Vec3f(-0.55f, 0.75f, -0.38f), render::Vec3f::UnitZ(), 30.0f,
                                        static_cast<float>(o.width) / static_cast<float>(o.height)));
  std::size_t inside = 0;
  for (const formats::FaceClass c : bundle.walls->face_class) inside += c == formats::FaceClass::Inside ? 1 : 0;
  std::printf("\nTessellated relief, every tet apart and every face open (%zu tets, %zu faces inside the solid):\n\n",
              cage.tet_count(), inside);
  std::printf("| level cap | draw ms | ÷ flat walls |\n|---|---|---|\n");
  double flat = 0;
  std::vector<std::uint8_t> pixels;
  for (const float level : {1.0f, 2.0f, 4.0f, 8.0f, 16.0f, 32.0f, 64.0f}) {
    renderer.set_tessellation(level);
    std::vector<double> draws;
    for (int f = 0; f <= o.frames; ++f) {
      renderer.render(pixels);
      if (f > 0) draws.push_back(renderer.last_stats().draw_ms);
    }
    const double ms = median(draws);
    if (level == 1.0f) flat = ms;
    std::printf("| %s | %.1f | %.2f× |\n", level == 1.0f ? "off" : std::to_string(static_cast<int>(level)).c_str(), ms, ms / flat);
    std::fflush(stdout);
  }
}

/// What the surroundings cost (issue 44): the mesh in its cage drawn bare (no ground:
/// the rows above), on a ground with its sky, and with the shadows too; the three drawn
/// in turn each frame, so load on the machine falls on all alike.
void measure_surroundings(const SurfaceMesh& mesh, const TetMesh& cage, const Options& o) {
  bake::BakeOptions bake_options;
  bake_options.collision = false;
  const formats::Bundle bundle = bake::embed(mesh, cage, bake_options, "mesh", "cage");
  sim::WorldSettings settings;
  settings.collisions = false;
  settings.step.gravity.setZero();
  const sim::BodyDescription body = testing::describe("body", cage, sim::Material{});
  const double floor = cage.rest_positions.row(2).minCoeff();
  sim::Environment environment;
  environment.ground = sim::Plane{Vec3::UnitZ(), floor - 0.05 * (cage.rest_positions.row(2).maxCoeff() - floor), {}};
  const sim::World bare_world({body}, {}, {}, settings), ground_world({body}, environment, {}, settings);
  const std::vector<player::BodyAssets> assets{{"mesh.h5", bundle, 1.0, {}, {}}};
  render::Renderer bare(o.width, o.height), patch(o.width, o.height), ground(o.width, o.height);
  const player::SceneView bare_view(bare_world, assets, bare), patch_view(bare_world, assets, patch),
      ground_view(ground_world, assets, ground);
  // The ground as it was drawn before issue 44: a plain square, 25 body sizes each way.
  render::PlainMesh square;
  const float z = static_cast<float>(environment.ground->offset), half = 25.0f * static_cast<float>(cage.rest_positions.norm());
  square.positions = {-half, -half, z, half, -half, z, half, half, z, -half, half, z};
  square.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
  square.triangles = {0, 1, 2, 0, 2, 3};
  patch.add_plain(square);
  std::vector<double> bare_ms, patch_ms, ground_ms, shadow_ms;
  std::vector<std::uint8_t> pixels;
  for (int f = 0; f <= o.frames; ++f) {
    bare.render(pixels);
    patch.render(pixels);
    ground.set_shadows(false);
    ground.render(pixels);
    const double unshadowed = ground.last_stats().draw_ms;
    ground.set_shadows(true);
    ground.render(pixels);
    if (f == 0) continue;  // the first frame uploads the static buffers
    bare_ms.push_back(bare.last_stats().draw_ms);
    patch_ms.push_back(patch.last_stats().draw_ms);
    ground_ms.push_back(unshadowed);
    shadow_ms.push_back(ground.last_stats().draw_ms);
  }
  const double b = median(bare_ms);
  std::printf("\nSurroundings, %zu triangles in %zu tets (the same frames, drawn in turn):\n\n", mesh.triangle_count(),
              cage.tet_count());
  std::printf("| scene | draw ms | ÷ bare |\n|---|---|---|\n");
  std::printf("| bare (no ground) | %.1f | 1.00× |\n", b);
  std::printf("| a plain square of ground (before issue 44) | %.1f | %.2f× |\n", median(patch_ms), median(patch_ms) / b);
  std::printf("| ground and sky | %.1f | %.2f× |\n", median(ground_ms), median(ground_ms) / b);
  std::printf("| ground, sky and shadows | %.1f | %.2f× |\n", median(shadow_ms), median(shadow_ms) / b);
  std::fflush(stdout);
}

TetMesh sample_cage(const std::string& tets) {
  return formats::read_cage(std::filesystem::path(FISSURE_BENCH_DATA_DIR) / "cages" / ("bunny-5k-cage-" + tets + ".node")).mesh;
}

void print_row(const Row& r, testing::CsvTable& csv) {
  std::printf("| %zu | %zu | %zu | %.2f | %.2f | %.1f | %.1f | %.2f× | %zu |\n", r.triangles, r.tets, r.instances, r.bake_s,
              r.step_ms, r.embedded_ms, r.plain_ms, r.embedded_ms / r.plain_ms, r.upload_bytes);
  std::fflush(stdout);
  csv.row({r.triangles, r.tets, r.instances, r.bake_s, r.step_ms, r.embedded_ms, r.plain_ms, r.upload_bytes});
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Options o = parse(argc, argv);
    std::vector<std::pair<std::string, TetMesh>> cages{{"987", sample_cage("987")}};
    if (!o.shared.empty()) {
      cages.emplace_back("10024", formats::read_cage(o.shared / "cages" / "bunny-5k-cage-10024.node").mesh);
    }
    std::vector<SurfaceMesh> meshes{
        bake::import_render_mesh(std::filesystem::path(FISSURE_BENCH_DATA_DIR) / "meshes" / "bunny-5k.obj").mesh};
    for (int k = 0; k < o.subdivisions; ++k) meshes.push_back(testing::subdivide(meshes.back()));
    const auto context = render::create_headless_context(o.backend);
    std::printf("%s, %dx%d, median of %d frames; physics: CG (lagged Cholesky, 1e-4), median of 20 steps\n\n",
                context->description().c_str(), o.width, o.height, o.frames);
    std::printf("| triangles | tets | instances | bake s | physics ms/step | embedded draw ms | plain draw ms | embedded ÷ plain | upload bytes/frame |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|\n");
    testing::CsvTable csv(o.csv, "draw", {"triangles", "tets", "instances", "bake_s", "physics_ms_per_step",
                                          "embedded_draw_ms", "plain_draw_ms", "upload_bytes_per_frame"});
    for (const auto& [name, cage] : cages) {
      for (const SurfaceMesh& mesh : meshes) {
        render::Renderer renderer(o.width, o.height);  // one per case: only its own bodies
        print_row(measure(mesh, cage, o, renderer), csv);
      }
    }
    for (const std::string& tets : o.cage_sweep) {
      if (std::any_of(cages.begin(), cages.end(), [&](const auto& c) { return c.first == tets; })) continue;
      render::Renderer renderer(o.width, o.height);
      print_row(measure(meshes.front(), sample_cage(tets), o, renderer), csv);
    }
    measure_surroundings(meshes.front(), cages.front().second, o);
    if (o.tessellation) measure_tessellation(meshes.front(), cages.front().second, o);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
