// The renderer, headless (OSMesa and EGL on llvmpipe): the embedded mesh drawn from its
// cage against the original mesh drawn directly, at rest and deformed; the backends
// against each other; shader errors.
#include "player/render/renderer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>

#include "bake/bake.h"
#include "common/error.h"
#include "formats/image.h"
#include "player/app/scene_view.h"
#include "player/render/camera_math.h"
#include "player/render/context.h"
#include "player/render/shapes.h"
#include "player/render/shader_program.h"
#include "tests/support/image_compare.h"
#include "tests/support/mapped_mesh.h"
#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"
#include "tests/support/temp_dir.h"

namespace fissure {
namespace {

using render::Vec3f;

constexpr int kSize = 192;

/// A sphere of 1,280 triangles in a 4×4×4-cube cage (384 tets): most triangles cross
/// tet faces, so most are drawn as several clipped instances.
struct EmbeddedSphere {
  SurfaceMesh mesh = testing::icosphere(3, 0.4, Vec3(0.5, 0.5, 0.5));
  TetMesh cage = testing::grid_cage(Vec3(0, 0, 0), Vec3(1, 1, 1), 4, 4, 4);
  formats::Bundle bundle;
  EmbeddedSphere() {
    bake::BakeOptions options;
    options.walls = options.collision = false;
    bundle = bake::embed(mesh, cage, options, "icosphere", "grid");
  }
  /// A world of the one body, its nodes at x (rest when empty), nothing moving it.
  [[nodiscard]] std::unique_ptr<sim::World> world(const Matrix3Xd& x = {}) const {
    sim::BodyDescription d = testing::describe("sphere", cage, sim::Material{});
    d.positions = x;
    sim::WorldSettings settings;
    settings.step.gravity.setZero();
    settings.collisions = false;
    return std::make_unique<sim::World>(std::vector<sim::BodyDescription>{d}, sim::Environment{},
                                        std::vector<sim::Projectile>{}, settings);
  }
};

const EmbeddedSphere& sphere() {
  static const EmbeddedSphere s;
  return s;
}

struct RenderPair {
  formats::Image embedded, direct;
};

/// Renders the sphere's world embedded, with `set_view`'s settings, then `expected` (what
/// it must equal, drawn on the CPU as plain meshes) in its place, with the same camera.
RenderPair render_against(const sim::World& world, const std::function<void(render::Renderer&)>& set_view,
                          const std::vector<render::PlainMesh>& expected,
                          render::Backend backend = render::Backend::OSMesa) {
  const auto context = render::create_headless_context(backend);
  render::Renderer renderer(kSize, kSize);
  const std::vector<player::BodyAssets> assets{{"sphere.h5", sphere().bundle, 1.0, {}, {}}};
  player::SceneView view(world, assets, renderer);
  // Closer than the view's own framing, which leaves room for motion: the sphere fills
  // most of the frame, so a mismatch has many pixels to show in.
  const Eigen::AlignedBox3f box(Eigen::Vector3f::Constant(0.05f), Eigen::Vector3f::Constant(0.95f));
  renderer.set_camera(render::frame_box(box, render::Vec3f(-0.55f, 0.75f, -0.38f), render::Vec3f::UnitZ(), 35.0f, 1.0f));
  RenderPair out{{kSize, kSize, {}}, {kSize, kSize, {}}};
  set_view(renderer);
  renderer.render(out.embedded.rgba);
  renderer.set_body_visible(0, false);
  for (const render::PlainMesh& mesh : expected) renderer.add_plain(mesh);
  renderer.render(out.direct.rgba);
  return out;
}

/// Renders the sphere's world embedded, then the CPU-mapped mesh with the same camera.
RenderPair render_both(const sim::World& world, render::Backend backend = render::Backend::OSMesa) {
  const sim::ImplicitIntegrator& body = world.bodies()[0].integrator();
  return render_against(world, [](render::Renderer&) {},
                        {testing::mapped_mesh(sphere().bundle, body.positions(), body.elasticity().tets())}, backend);
}

void expect_match(const RenderPair& pair, const std::string& name, const testing::ImageTolerance& tolerance = {}) {
  // FISSURE_TEST_IMAGE_DIR=folder keeps both renders of every comparison, to look at.
  if (const char* keep = std::getenv("FISSURE_TEST_IMAGE_DIR"); keep != nullptr) {
    formats::write_png(std::filesystem::path(keep) / (name + "-embedded.png"), pair.embedded);
    formats::write_png(std::filesystem::path(keep) / (name + "-direct.png"), pair.direct);
  }
  static const testing::TempDir dir;
  const std::filesystem::path diff = dir.path() / (name + "-diff.png");
  const testing::ImageDifference d = testing::compare_images(pair.embedded, pair.direct, tolerance, diff);
  EXPECT_LE(d.fraction(), tolerance.max_failing_fraction)
      << d.failing << " of " << d.pixels << " pixels differ; diff image: " << diff;
  // Something was drawn: not a blank image matching a blank image.
  std::size_t foreground = 0;
  for (std::size_t i = 0; i < pair.direct.rgba.size(); i += 4) foreground += pair.direct.rgba[i] != pair.direct.rgba[0];
  EXPECT_GT(foreground, pair.direct.rgba.size() / 4 / 10) << name << ": the sphere should fill part of the frame";
}

TEST(Render, TheEmbeddedMeshAtRestMatchesTheOriginalMesh) {
  expect_match(render_both(*sphere().world()), "rest");
}

TEST(Render, UnderARigidMotionAndAnAffineDeformationItMatchesTheMeshMappedOnTheCpu) {
  const Matrix3Xd& rest = sphere().cage.rest_positions;
  const Mat3 rotation = testing::rotation(0.7, Vec3(1, 2, 3));
  expect_match(render_both(*sphere().world((rotation * rest).colwise() + Vec3(0.1, -0.2, 0.05))), "rigid");
  // Shear and stretch: normals must follow F⁻ᵀ, not the rotation alone.
  Mat3 affine;
  affine << 1.3, 0.4, 0.0, 0.0, 0.8, 0.2, 0.1, 0.0, 1.1;
  expect_match(render_both(*sphere().world(affine * rest)), "affine");
}

TEST(Render, UnderABendTheEmbeddedMeshHasNoHoles) {
  // Each tet moves by its own affine map, so the surface kinks at tet faces: shading
  // differs a little from the smooth CPU normals, but no background may show inside.
  Matrix3Xd bent = sphere().cage.rest_positions;
  for (Eigen::Index n = 0; n < bent.cols(); ++n) bent(2, n) += 0.3 * std::pow(bent(0, n) - 0.5, 2);
  const RenderPair pair = render_both(*sphere().world(bent));
  const std::uint8_t background[3] = {pair.direct.rgba[0], pair.direct.rgba[1], pair.direct.rgba[2]};
  EXPECT_EQ(testing::holes(pair.embedded, pair.direct, background), 0u);
  expect_match(pair, "bent", {.max_abs = 24, .shift = 1, .max_failing_fraction = 5e-3});
}

/// The world's collision spheres as plain spheres placed on the CPU.
std::vector<render::PlainMesh> spheres_on_cpu(const sim::World& world) {
  const sim::Body& body = world.bodies()[0];
  const render::PlainMesh unit = render::unit_sphere(render::kDebugSphereRings, render::kDebugSphereSegments);
  render::PlainMesh all;
  all.color = render::EmbeddedMesh{}.sphere_color;
  for (std::size_t k = 0; k < body.spheres.size(); ++k) {
    const Vec3 centre = sim::embedded_position(body.integrator().positions(), body.integrator().elasticity().tets(), body.spheres, k);
    const auto first = static_cast<std::uint32_t>(all.positions.size() / 3);
    for (std::size_t v = 0; v < unit.positions.size(); ++v) {
      all.positions.push_back(static_cast<float>(centre[static_cast<Eigen::Index>(v % 3)] + body.spheres.radius[k] * unit.positions[v]));
    }
    all.normals.insert(all.normals.end(), unit.normals.begin(), unit.normals.end());
    for (const std::uint32_t i : unit.triangles) all.triangles.push_back(first + i);
  }
  return {all};
}

TEST(Render, TheSphereViewDrawsThePhysicsCollisionSpheresWhereTheCpuPlacesThem) {
  const auto show_spheres = [](render::Renderer& r) { r.set_spheres_visible(true); };
  const auto rest = sphere().world();
  ASSERT_GT(rest->bodies()[0].spheres.size(), 100u);
  expect_match(render_against(*rest, show_spheres, spheres_on_cpu(*rest)), "spheres-rest");
  Mat3 affine;
  affine << 1.3, 0.4, 0.0, 0.0, 0.8, 0.2, 0.1, 0.0, 1.1;
  const auto sheared = sphere().world(affine * sphere().cage.rest_positions);
  expect_match(render_against(*sheared, show_spheres, spheres_on_cpu(*sheared)), "spheres-affine");
}

TEST(Render, TheReplicationViewColoursEachTriangleByHowManyTetsItIsDrawnIn) {
  // Expected: the CPU-placed mesh split by replica count, each part in its colour.
  const formats::Bundle& bundle = sphere().bundle;
  std::vector<std::uint32_t> replicas(static_cast<std::size_t>(bundle.render.triangles.cols()), 0);
  for (const TriangleIndex t : bundle.embedding.instance_triangle) ++replicas[t];
  const auto world = sphere().world();
  const sim::ImplicitIntegrator& body = world->bodies()[0].integrator();
  const render::PlainMesh whole = testing::mapped_mesh(bundle, body.positions(), body.elasticity().tets());
  std::vector<render::PlainMesh> parts(5, whole);
  std::array<std::size_t, 5> count{};
  for (std::size_t k = 0; k < parts.size(); ++k) {
    parts[k].triangles.clear();
    parts[k].color = render::replication_color(static_cast<std::uint32_t>(k + 1));
  }
  for (std::size_t t = 0; t < replicas.size(); ++t) {
    const std::size_t k = std::min<std::size_t>(replicas[t], 5) - 1;
    ++count[k];
    parts[k].triangles.insert(parts[k].triangles.end(), &whole.triangles[3 * t], &whole.triangles[3 * t] + 3);
  }
  // The sphere in its 4³ cage has triangles drawn once, twice and three or more times.
  EXPECT_GT(count[0], 0u);
  EXPECT_GT(count[1], 0u);
  EXPECT_GT(count[2] + count[3] + count[4], 0u);
  const auto colour_replicas = [](render::Renderer& r) { r.set_replication_colors(true); };
  expect_match(render_against(*world, colour_replicas, parts), "replication");
}

// A forced fracture: the cage cut along x = 0.5, its right half moved out of view, and
// the cut faces marked open. Seen face-on from +x, the left half's walls must cover the
// sphere's cross-section and nothing else: the cut faces outside the sphere are classed
// outside the solid, and the crossing ones show only their solid part.
TEST(Render, WallsShowExactlyTheSolidPartOfTheFacesFractureOpened) {
  const EmbeddedSphere& s = sphere();
  bake::BakeOptions options;
  options.collision = false;
  const formats::Bundle bundle = bake::embed(s.mesh, s.cage, options, "icosphere", "grid");
  const TetMesh& cage = s.cage;
  // The right half's tets take copies of the plane's nodes, 5 m away along y.
  Matrix3Xd x = cage.rest_positions;
  Matrix4Xu tets = cage.tets;
  std::vector<Index> copy(cage.node_count(), kInvalidIndex);
  for (TetIndex t = 0; t < cage.tet_count(); ++t) {
    Vec3 centroid = Vec3::Zero();
    for (int i = 0; i < 4; ++i) centroid += 0.25 * x.col(tets(i, t));
    if (centroid.x() < 0.5) continue;
    for (int i = 0; i < 4; ++i) {
      Index& n = tets(i, t);
      if (cage.rest_positions(0, n) > 0.5) continue;
      if (copy[n] == kInvalidIndex) {
        copy[n] = static_cast<Index>(x.cols());
        x.conservativeResize(Eigen::NoChange, x.cols() + 1);
        x.col(copy[n]) = cage.rest_positions.col(n);
      }
      n = copy[n];
    }
  }
  for (Eigen::Index n = 0; n < x.cols(); ++n) {
    const bool right = n >= static_cast<Eigen::Index>(cage.node_count()) || cage.rest_positions(0, n) > 0.5;
    if (right) x(1, n) += 5.0;
  }
  std::vector<std::uint8_t> faces(4 * cage.tet_count(), 0);
  for (TetIndex t = 0; t < cage.tet_count(); ++t) {
    for (int k = 0; k < 4; ++k) {
      const FaceIndex f = bundle.faces.tet_faces(k, t);
      bool on_cut = !bundle.faces.is_boundary(f);
      for (int j = 0; j < 3; ++j) on_cut = on_cut && cage.rest_positions(0, bundle.faces.nodes(j, f)) == 0.5;
      faces[4 * t + k] = on_cut ? 2 : 0;
    }
  }
  const std::vector<float> positions(x.data(), x.data() + x.size());
  const std::vector<std::uint32_t> tet_nodes(tets.data(), tets.data() + tets.size());

  const auto context = render::create_headless_context(render::Backend::OSMesa);
  render::Renderer renderer(kSize, kSize);
  const auto world = s.world();
  renderer.add_body(player::embedded_mesh(bundle, world->bodies()[0].integrator(), 1.0));
  renderer.set_pose(0, {positions, tet_nodes, faces, {}, 1});
  render::Camera camera;
  camera.eye = Vec3f(3.0f, 0.5f, 0.5f);
  camera.target = Vec3f(0.5f, 0.5f, 0.5f);
  renderer.set_camera(camera);
  formats::Image walls{kSize, kSize, {}}, open{kSize, kSize, {}}, flat{kSize, kSize, {}}, relief{kSize, kSize, {}};
  renderer.set_tessellation(16.0f, 2.0f);
  renderer.render(relief.rgba);
  renderer.set_tessellation(1.0f);
  renderer.render(walls.rgba);
  renderer.set_normal_mapping(false);
  renderer.render(flat.rgba);
  renderer.set_walls_visible(false);
  renderer.render(open.rgba);
  if (const char* keep = std::getenv("FISSURE_TEST_IMAGE_DIR"); keep != nullptr) {
    formats::write_png(std::filesystem::path(keep) / "walls-on.png", walls);
    formats::write_png(std::filesystem::path(keep) / "walls-off.png", open);
  }

  // Wall pixels: where the walls changed the image. The open half shows its inside
  // there, so the cross-section is the foreground of the image without walls.
  const auto at = [&](const formats::Image& image, int px, int py) { return &image.rgba[4 * (py * kSize + px)]; };
  const auto foreground = [&](int px, int py) { return !std::equal(at(open, px, py), at(open, px, py) + 3, at(open, 0, 0)); };
  std::size_t wall = 0, section = 0, stray = 0, flat_wall = 0, relit = 0, relief_wall = 0, relief_stray = 0;
  std::size_t bare = 0, relief_bare = 0;  // section pixels a pixel or more inside its edge that no wall covers
  for (int py = 0; py < kSize; ++py) {
    for (int px = 0; px < kSize; ++px) {
      const bool is_wall = !std::equal(at(walls, px, py), at(walls, px, py) + 3, at(open, px, py));
      section += foreground(px, py) ? 1 : 0;
      wall += is_wall ? 1 : 0;
      // Normal mapping changes the walls' shading, never which pixels they cover.
      const bool is_flat_wall = !std::equal(at(flat, px, py), at(flat, px, py) + 3, at(open, px, py));
      flat_wall += is_flat_wall ? 1 : 0;
      relit += is_wall && !std::equal(at(flat, px, py), at(flat, px, py) + 3, at(walls, px, py)) ? 1 : 0;
      bool near_section = false, inside_section = true;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int qx = std::clamp(px + dx, 0, kSize - 1), qy = std::clamp(py + dy, 0, kSize - 1);
          near_section = near_section || foreground(qx, qy);
          inside_section = inside_section && foreground(qx, qy);
        }
      }
      stray += is_wall && !near_section ? 1 : 0;
      bare += inside_section && !is_wall ? 1 : 0;
      const bool is_relief_wall = !std::equal(at(relief, px, py), at(relief, px, py) + 3, at(open, px, py));
      relief_wall += is_relief_wall ? 1 : 0;
      relief_stray += is_relief_wall && !near_section ? 1 : 0;
      relief_bare += inside_section && !is_relief_wall ? 1 : 0;
    }
  }
  std::printf("walls: %zu wall pixels over a cross-section of %zu, %zu outside it, %zu inside it bare\n", wall, section,
              stray, bare);
  EXPECT_GT(section, static_cast<std::size_t>(kSize * kSize / 10));
  EXPECT_EQ(stray, 0u);  // never over a face outside the solid
  // And over all of the section but its edge: the walls stop half a texel inside the
  // contour, and the surface reaches half a pixel past the cut (renderer.cpp,
  // embedded.frag.glsl), which leaves at most a pixel's ring.
  EXPECT_LE(bare, section / 500);
  EXPECT_GE(wall, section - section / 20);
  EXPECT_EQ(flat_wall, wall);
  EXPECT_GT(relit, wall / 2) << "the detail normals should change most wall pixels' shading";
  // Tessellated relief moves the walls along their normals, faded to nothing at their
  // edges: seen face-on they still cover the section, and nothing beside it.
  EXPECT_EQ(relief_stray, 0u);
  EXPECT_LE(relief_bare, section / 500);
  EXPECT_GE(relief_wall, section - section / 20);
}

/// The sphere in a finer cage (6³ cubes), where many faces lie wholly inside it.
struct FineSphere {
  TetMesh cage = testing::grid_cage(Vec3(0, 0, 0), Vec3(1, 1, 1), 6, 6, 6);
  formats::Bundle bundle;
  std::unique_ptr<sim::World> world;
  FineSphere() {
    bake::BakeOptions options;
    options.collision = false;
    bundle = bake::embed(sphere().mesh, cage, options, "icosphere", "grid");
    sim::WorldSettings settings;
    settings.collisions = false;
    world = std::make_unique<sim::World>(std::vector<sim::BodyDescription>{testing::describe("sphere", cage, sim::Material{})},
                                         sim::Environment{}, std::vector<sim::Projectile>{}, settings);
  }
};

/// Every inside-the-solid face of the intact fine sphere opened as a wall, relief
/// `factor` times the bake's clearance, tessellated at `level` (1: off): the image, from
/// the test's usual oblique view.
formats::Image interior_walls_image(double factor, float level, bool walls = true) {
  static const FineSphere s;
  render::EmbeddedMesh mesh = player::embedded_mesh(s.bundle, s.world->bodies()[0].integrator(), 1.0);
  std::vector<std::uint8_t> faces(4 * s.cage.tet_count(), 0);
  for (TetIndex t = 0; t < s.cage.tet_count(); ++t) {
    for (int k = 0; k < 4; ++k) {
      const FaceIndex f = s.bundle.faces.tet_faces(k, t);
      if (s.bundle.walls->face_class[f] != formats::FaceClass::Inside) continue;
      faces[4 * t + k] = 2;
      mesh.face_relief[4 * t + k] = static_cast<float>(factor * s.bundle.walls->face_clearance[f]);
    }
  }
  const Matrix3Xd& x = s.cage.rest_positions;
  const std::vector<float> positions(x.data(), x.data() + x.size());
  const std::vector<std::uint32_t> tets(s.cage.tets.data(), s.cage.tets.data() + s.cage.tets.size());
  const auto context = render::create_headless_context(render::Backend::OSMesa);
  render::Renderer renderer(kSize, kSize);
  renderer.add_body(mesh);
  renderer.set_pose(0, {positions, tets, faces, {}, 1});
  renderer.set_walls_visible(walls);
  renderer.set_tessellation(level, 3.0f);
  const Eigen::AlignedBox3f box(Eigen::Vector3f::Constant(0.05f), Eigen::Vector3f::Constant(0.95f));
  renderer.set_camera(render::frame_box(box, render::Vec3f(-0.55f, 0.75f, -0.38f), render::Vec3f::UnitZ(), 35.0f, 1.0f));
  formats::Image image{kSize, kSize, {}};
  renderer.render(image.rgba);
  if (const char* keep = std::getenv("FISSURE_TEST_IMAGE_DIR"); keep != nullptr) {
    formats::write_png(std::filesystem::path(keep) / ("relief-" + std::to_string(factor) + "-" + std::to_string(level) + ".png"), image);
  }
  return image;
}

std::size_t differing_pixels(const formats::Image& a, const formats::Image& b) {
  std::size_t count = 0;
  for (std::size_t i = 0; i < a.rgba.size(); i += 4) count += !std::equal(&a.rgba[i], &a.rgba[i] + 3, &b.rgba[i]);
  return count;
}

// Relief raises and sinks the interior walls by at most the bake's clearance, so walls
// opened inside an intact solid stay hidden behind its outer surface: no pixel changes.
// Far more relief does poke through, so the check can see a violation. (It takes far
// more: a face's clearance is its least depth, usually at a corner, where the relief
// fades to nothing.)
TEST(Render, TessellatedReliefWithinTheClearanceNeverPokesThroughTheOutside) {
  const formats::Image no_walls = interior_walls_image(1.0, 12.0f, false);
  EXPECT_EQ(differing_pixels(interior_walls_image(0.0, 1.0f), no_walls), 0u);
  EXPECT_EQ(differing_pixels(interior_walls_image(1.0, 12.0f), no_walls), 0u);
  const std::size_t poking = differing_pixels(interior_walls_image(40.0, 12.0f), no_walls);
  std::printf("relief at 40× the clearance: %zu pixels poke through\n", poking);
  EXPECT_GT(poking, 100u) << "relief far beyond the clearance should show through the surface";
}

/// Differing pixels between two images, and how many of them are specks: connected
/// (8-neighbour) groups of at most 2 differing pixels.
struct Specks {
  std::size_t differing = 0, specks = 0;
};
Specks count_specks(const formats::Image& a, const formats::Image& b) {
  const int w = a.width, h = a.height;
  std::vector<int> differs(static_cast<std::size_t>(w) * h, 0);
  Specks out;
  for (std::size_t i = 0; i < differs.size(); ++i) {
    differs[i] = std::equal(&a.rgba[4 * i], &a.rgba[4 * i] + 3, &b.rgba[4 * i]) ? 0 : 1;
    out.differing += static_cast<std::size_t>(differs[i]);
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (differs[static_cast<std::size_t>(y) * w + x] != 1) continue;
      std::vector<std::pair<int, int>> group{{x, y}};
      differs[static_cast<std::size_t>(y) * w + x] = 2;
      for (std::size_t k = 0; k < group.size() && group.size() <= 2; ++k) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int qx = group[k].first + dx, qy = group[k].second + dy;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h || differs[static_cast<std::size_t>(qy) * w + qx] != 1) continue;
            differs[static_cast<std::size_t>(qy) * w + qx] = 2;
            group.emplace_back(qx, qy);
          }
        }
      }
      if (group.size() <= 2) out.specks += group.size();
    }
  }
  return out;
}

/// The fine sphere drawn at rest from `direction`, `size` pixels square: either whole
/// (`split` false: its own tets, no face opened) or with every tet on its own copies of
/// its nodes, at the same positions, and every shared face opened as a wall.
formats::Image split_sphere_image(bool split, const render::Vec3f& direction, int size, render::Backend backend) {
  static const FineSphere s;
  const TetMesh& cage = s.cage;
  std::vector<float> positions;
  std::vector<std::uint32_t> tets;
  std::vector<std::uint8_t> faces(4 * cage.tet_count(), 0);
  for (TetIndex t = 0; t < cage.tet_count(); ++t) {
    for (int i = 0; i < 4; ++i) {
      const Index n = cage.tets(i, t);
      if (!split) {
        tets.push_back(static_cast<std::uint32_t>(n));
        continue;
      }
      tets.push_back(static_cast<std::uint32_t>(positions.size() / 3));
      for (int c = 0; c < 3; ++c) positions.push_back(static_cast<float>(cage.rest_positions(c, n)));
      faces[4 * t + i] = s.bundle.faces.is_boundary(s.bundle.faces.tet_faces(i, t)) ? 0 : 2;
    }
  }
  if (!split) positions.assign(cage.rest_positions.data(), cage.rest_positions.data() + cage.rest_positions.size());
  const auto context = render::create_headless_context(backend);
  render::Renderer renderer(size, size);
  renderer.add_body(player::embedded_mesh(s.bundle, s.world->bodies()[0].integrator(), 1.0));
  renderer.set_pose(0, {positions, tets, faces, {}, 1});
  const Eigen::AlignedBox3f box(Eigen::Vector3f::Constant(0.05f), Eigen::Vector3f::Constant(0.95f));
  renderer.set_camera(render::frame_box(box, direction, render::Vec3f::UnitZ(), 35.0f, 1.0f));
  formats::Image image{size, size, {}};
  renderer.render(image.rgba);
  return image;
}

// Issue 44: a body whose faces fracture has all opened, but whose pieces have not moved,
// must look like the whole body: its walls all lie inside the solid or meet the surface
// exactly, so none may show through it, not even as a speck. (Before the walls were
// kept off their seams: 90-170 differing pixels a view, all specks.)
TEST(Render, ABodySplitAlongEveryFaceButUnmovedLooksWhole) {
  constexpr int kLarge = 480;
  const std::vector<render::Vec3f> directions{
      render::Vec3f(-0.55f, 0.75f, -0.38f), render::Vec3f(0.3f, 0.2f, -0.9f), render::Vec3f(1.0f, 0.02f, 0.01f),
      render::Vec3f(0.6f, 0.7f, 0.4f),      render::Vec3f(-0.2f, -1.0f, 0.3f), render::Vec3f(-0.7f, -0.1f, 0.7f)};
  for (const render::Backend backend : {render::Backend::OSMesa, render::Backend::Egl}) {
    for (std::size_t view = 0; view < directions.size(); ++view) {
      const formats::Image whole = split_sphere_image(false, directions[view], kLarge, backend);
      const formats::Image split = split_sphere_image(true, directions[view], kLarge, backend);
      if (const char* keep = std::getenv("FISSURE_TEST_IMAGE_DIR"); keep != nullptr) {
        const std::string suffix = std::to_string(view) + ".png";
        formats::write_png(std::filesystem::path(keep) / ("split-whole-" + suffix), whole);
        formats::write_png(std::filesystem::path(keep) / ("split-split-" + suffix), split);
      }
      const Specks d = count_specks(split, whole);
      std::printf("split and unmoved, view %zu: %zu of %d pixels differ, %zu in specks\n", view, d.differing,
                  kLarge * kLarge, d.specks);
      EXPECT_LE(static_cast<double>(d.differing), 1e-4 * kLarge * kLarge) << "view " << view;
      EXPECT_EQ(d.specks, 0u) << "view " << view;
    }
  }
}

/// Pixels darker by more than `by` (green, of 255) than all 8 of their neighbours.
std::size_t dark_specks(const formats::Image& image, int by = 40) {
  const auto green = [&](int x, int y) { return int(image.rgba[4 * (static_cast<std::size_t>(y) * image.width + x) + 1]); };
  std::size_t count = 0;
  for (int y = 1; y + 1 < image.height; ++y) {
    for (int x = 1; x + 1 < image.width; ++x) {
      bool isolated = true;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) isolated = isolated && ((dx == 0 && dy == 0) || green(x + dx, y + dy) - green(x, y) > by);
      }
      count += isolated ? 1 : 0;
    }
  }
  return count;
}

// Issue 44: a smooth normal near a silhouette leans past its triangle's plane; turned
// over by its own sign it was shaded as facing away from the light, a dark speck on the
// contour. The whole sphere from six sides shows none.
TEST(Render, SilhouettesHaveNoDarkSpecks) {
  for (const render::Vec3f& direction :
       {render::Vec3f(-0.55f, 0.75f, -0.38f), render::Vec3f(0.3f, 0.2f, -0.9f), render::Vec3f(1.0f, 0.02f, 0.01f),
        render::Vec3f(0.6f, 0.7f, 0.4f), render::Vec3f(-0.2f, -1.0f, 0.3f), render::Vec3f(-0.7f, -0.1f, 0.7f)}) {
    const std::size_t specks = dark_specks(split_sphere_image(false, direction, 480, render::Backend::OSMesa));
    std::printf("dark specks: %zu\n", specks);
    EXPECT_EQ(specks, 0u) << direction.transpose();
  }
}

// Golden images: the renderer against itself over time, so a change that alters what a
// scene looks like shows up. Compared with a tolerance (a Mesa update may move a few
// pixels). To accept a deliberate change, rerun with FISSURE_UPDATE_GOLDEN=1 and commit
// tests/render/golden/*.png after looking at them.
void expect_golden(const formats::Image& image, const std::string& name) {
  const std::filesystem::path golden = std::filesystem::path(FISSURE_GOLDEN_DIR) / (name + ".png");
  if (std::getenv("FISSURE_UPDATE_GOLDEN") != nullptr) {
    formats::write_png(golden, image);
    return;
  }
  ASSERT_TRUE(std::filesystem::exists(golden)) << golden << " is missing: run with FISSURE_UPDATE_GOLDEN=1";
  static const testing::TempDir dir;
  const std::filesystem::path diff = dir.path() / (name + "-golden-diff.png");
  const testing::ImageDifference d =
      testing::compare_images(image, formats::read_png(golden), {.max_abs = 4, .shift = 1, .max_failing_fraction = 1e-3}, diff);
  EXPECT_LE(d.fraction(), 1e-3) << name << ": " << d.failing << " pixels differ from " << golden << "; diff: " << diff;
}

TEST(Render, TheSphereAtRestAndBentMatchesItsGoldenImages) {
  expect_golden(render_both(*sphere().world()).embedded, "sphere-rest");
  Matrix3Xd bent = sphere().cage.rest_positions;
  for (Eigen::Index n = 0; n < bent.cols(); ++n) bent(2, n) += 0.3 * std::pow(bent(0, n) - 0.5, 2);
  expect_golden(render_both(*sphere().world(bent)).embedded, "sphere-bent");
}

/// The sphere hanging 0.3 m over a ground (z = -0.2), drawn by the player's scene view
/// (its ground, sky and light), from a camera that sees the horizon.
struct GroundScene {
  formats::Image shadowed{kSize, kSize, {}}, unshadowed{kSize, kSize, {}};
  render::Camera camera;
  render::Light light;
};
GroundScene render_over_ground(render::Backend backend = render::Backend::OSMesa) {
  sim::Environment environment;
  environment.ground = sim::Plane{Vec3::UnitZ(), -0.2, {}};
  sim::WorldSettings settings;
  settings.step.gravity.setZero();
  settings.collisions = false;
  const sim::World world(std::vector<sim::BodyDescription>{testing::describe("sphere", sphere().cage, sim::Material{})},
                         environment, std::vector<sim::Projectile>{}, settings);
  const auto context = render::create_headless_context(backend);
  render::Renderer renderer(kSize, kSize);
  const std::vector<player::BodyAssets> assets{{"sphere.h5", sphere().bundle, 1.0, {}, {}}};
  player::SceneView view(world, assets, renderer);
  GroundScene out;
  out.camera.eye = Vec3f(0.5f, -2.6f, 0.8f);
  out.camera.target = Vec3f(0.5f, 0.5f, 0.45f);
  out.camera.far_plane = 60.0f;
  renderer.set_camera(out.camera);
  out.light.towards = Vec3f(0.3f, 0.2f, 1.0f).normalized();
  renderer.set_light(out.light);
  renderer.render(out.shadowed.rgba);
  renderer.set_shadows(false);
  renderer.render(out.unshadowed.rgba);
  if (const char* keep = std::getenv("FISSURE_TEST_IMAGE_DIR"); keep != nullptr) {
    formats::write_png(std::filesystem::path(keep) / "ground-shadowed.png", out.shadowed);
    formats::write_png(std::filesystem::path(keep) / "ground-unshadowed.png", out.unshadowed);
  }
  return out;
}

/// Where world point `p` lands in an image of `camera`, in pixels (top row 0).
Eigen::Vector2f pixel_of(const render::Camera& camera, const Vec3f& p) {
  const Eigen::Vector4f clip = render::perspective(camera, 1.0f) * render::look_at(camera) * p.homogeneous();
  return {(0.5f * clip.x() / clip.w() + 0.5f) * kSize, (0.5f - 0.5f * clip.y() / clip.w()) * kSize};
}

int green_at(const formats::Image& image, const Eigen::Vector2f& pixel) {
  const int x = std::clamp(static_cast<int>(pixel.x()), 0, kSize - 1), y = std::clamp(static_cast<int>(pixel.y()), 0, kSize - 1);
  return image.rgba[4 * (static_cast<std::size_t>(y) * kSize + x) + 1];
}

// Issue 44: the ground reads as ground (a checker in world units, fading into a sky
// that turns blue overhead) and the body's shadow falls on it where the light puts it.
TEST(Render, TheGroundHasACheckerASkyAndTheBodysShadowWhereTheLightPutsIt) {
  const GroundScene scene = render_over_ground();
  // The shadow: the sphere's centre cast along the light onto the ground is darker with
  // shadows than without; a ground point as far on the other side is not.
  const Vec3f centre(0.5f, 0.5f, 0.5f), towards = scene.light.towards;
  const Vec3f under = centre - (centre.z() + 0.2f) / towards.z() * towards;
  const Vec3f away = under + Vec3f(0.0f, -0.9f, 0.0f);
  const Eigen::Vector2f in_shadow = pixel_of(scene.camera, under), in_light = pixel_of(scene.camera, away);
  EXPECT_LT(green_at(scene.shadowed, in_shadow), 0.75 * green_at(scene.unshadowed, in_shadow)) << in_shadow.transpose();
  EXPECT_EQ(green_at(scene.shadowed, in_light), green_at(scene.unshadowed, in_light)) << in_light.transpose();
  std::size_t darker = 0, brighter = 0;
  for (std::size_t i = 0; i < scene.shadowed.rgba.size(); i += 4) {
    darker += scene.shadowed.rgba[i + 1] + 8 < scene.unshadowed.rgba[i + 1] ? 1 : 0;
    brighter += scene.shadowed.rgba[i + 1] > scene.unshadowed.rgba[i + 1] ? 1 : 0;
  }
  EXPECT_GT(darker, static_cast<std::size_t>(kSize * kSize / 100)) << "the shadow should cover some of the ground";
  EXPECT_EQ(brighter, 0u) << "a shadow only takes light away";
  // The checker (cells of 0.5 m here): along the ground in view, x in [-0.1, 1.1], the
  // tone changes at x = 0, 0.5 and 1.
  int changes = 0;
  for (float x = -0.125f; x < 1.1f; x += 0.05f) {
    const int a = green_at(scene.unshadowed, pixel_of(scene.camera, Vec3f(x, -0.4f, -0.2f)));
    const int b = green_at(scene.unshadowed, pixel_of(scene.camera, Vec3f(x + 0.05f, -0.4f, -0.2f)));
    changes += std::abs(a - b) > 3 ? 1 : 0;
  }
  EXPECT_EQ(changes, 3) << "the ground should show its checker";
  // The sky: bluer at the top of the image than at the horizon (whose blue exceeds its
  // red by 13 of 255).
  const std::uint8_t* top = &scene.shadowed.rgba[4 * (kSize / 2)];
  EXPECT_GT(int(top[2]) - int(top[0]), 20) << "the sky above the horizon should turn blue";
  expect_golden(scene.shadowed, "ground-shadow");
  // EGL draws the same.
  const testing::ImageDifference egl =
      testing::compare_images(render_over_ground(render::Backend::Egl).shadowed, scene.shadowed, {.max_abs = 1, .shift = 0});
  EXPECT_EQ(egl.failing, 0u);
}

// Issue 44 (issue 14's review): the view's near and far planes were frame 0's for the
// whole run, so a ball (or a piece) beyond frame 0's far plane was cut away. They now
// widen to hold every body and launched projectile.
TEST(Render, TheCameraPlanesHoldABallLaunchedBeyondFrameZerosFarPlane) {
  sim::WorldSettings settings;
  settings.step.gravity.setZero();
  settings.collisions = false;
  const std::vector<sim::BodyDescription> bodies{testing::describe("sphere", sphere().cage, sim::Material{})};
  const auto context = render::create_headless_context(render::Backend::OSMesa);
  render::Renderer renderer(kSize, kSize);
  const std::vector<player::BodyAssets> assets{{"sphere.h5", sphere().bundle, 1.0, {}, {}}};
  const sim::World bare(bodies, sim::Environment{}, {}, settings);
  const render::Camera start = player::SceneView(bare, assets, renderer).camera();
  const Vec3f view = (start.target - start.eye).normalized();
  sim::Projectile ball;
  ball.radius = 1.0;
  ball.position = (start.eye + 1.5f * start.far_plane * view).cast<double>();
  ball.launch_time = 0.0;
  sim::World world(bodies, sim::Environment{}, {ball}, settings);
  render::Renderer second(kSize, kSize);
  player::SceneView scene(world, assets, second);
  world.step();
  ASSERT_TRUE(world.projectiles()[0].launched);
  scene.update(world);
  const float depth = (world.projectiles()[0].position.cast<float>() - scene.camera().eye).dot(view);
  EXPECT_GT(scene.camera().far_plane, depth + 1.0f) << "frame 0's far plane was " << start.far_plane;
  EXPECT_LE(scene.camera().near_plane, start.near_plane);
}

TEST(Render, OSMesaAndEglDrawTheSameImage) {
  const auto world = sphere().world();
  const RenderPair osmesa = render_both(*world, render::Backend::OSMesa);
  const RenderPair egl = render_both(*world, render::Backend::Egl);
  const testing::ImageDifference d = testing::compare_images(egl.embedded, osmesa.embedded, {.max_abs = 1, .shift = 0});
  EXPECT_EQ(d.failing, 0u);
}

// Issue 44 (issue 14's review): a body's arrays are checked against each other before
// any GPU object is made; a corner naming a tet without a rest inverse, or a slot naming
// a missing tile, would read past a buffer on the GPU.
TEST(Render, AddBodyRejectsArraysThatDoNotMatchBeforeMakingAnything) {
  const auto context = render::create_headless_context(render::Backend::OSMesa);
  render::Renderer renderer(8, 8);
  render::EmbeddedMesh one;
  one.barycentric = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  one.tet = {0, 0, 0};
  one.rest_normal = {0, 0, 1, 0, 0, 1, 0, 0, 1};
  one.rest_inverse = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  one.face_tile.assign(4, render::kWallWhole);
  one.face_uv.assign(24, 0.0f);
  EXPECT_EQ(renderer.add_body(one), 0u);
  const auto expect_rejected = [&](render::EmbeddedMesh mesh, const std::string& says) {
    try {
      renderer.add_body(mesh);
      ADD_FAILURE() << "accepted a mesh whose " << says << " does not match";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  render::EmbeddedMesh past = one;
  past.tet = {0, 0, 3};
  expect_rejected(past, "tet");
  render::EmbeddedMesh tile = one;
  tile.face_tile[2] = 0;  // no tiles given
  expect_rejected(tile, "tiles");
  render::EmbeddedMesh slots = one;
  slots.face_tile.resize(3);
  expect_rejected(slots, "face slots");
  render::EmbeddedMesh relief = one;
  relief.face_relief = {0.1f};
  expect_rejected(relief, "relief");
  // Nothing half-made: the renderer still has its one body, and draws.
  std::vector<std::uint8_t> rgba;
  EXPECT_EQ(renderer.add_body(one), 1u);
  EXPECT_NO_THROW(renderer.render(rgba));
}

TEST(Render, ABrokenShaderNamesItsFileAndLine) {
  const auto context = render::create_headless_context(render::Backend::OSMesa);
  const std::string source = "#version 450 core\nout vec4 color;\nvoid main() { color = no_such_thing; }\n";
  try {
    render::ShaderProgram program({{"broken.frag.glsl", source}});
    FAIL() << "a broken shader compiled";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("shaders/broken.frag.glsl:3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace fissure
