// The renderer, headless (OSMesa and EGL on llvmpipe): the embedded mesh drawn from its
// cage against the original mesh drawn directly, at rest and deformed; the backends
// against each other; shader errors.
#include "player/render/renderer.h"

#include <gtest/gtest.h>

#include <cmath>

#include "bake/bake.h"
#include "common/error.h"
#include "formats/image.h"
#include "player/app/scene_view.h"
#include "player/render/context.h"
#include "player/render/shader_program.h"
#include "tests/support/image_compare.h"
#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"
#include "tests/support/temp_dir.h"

namespace fissure {
namespace {

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

/// The render mesh placed through its bindings on the CPU (each vertex from its first
/// instance) with smooth area-weighted normals: what the embedded render must show.
render::PlainMesh mapped_mesh(const formats::Bundle& bundle, const Matrix3Xd& x, const Matrix4Xu& tets) {
  const formats::Embedding& e = bundle.embedding;
  Matrix3Xd p = Matrix3Xd::Zero(3, bundle.render.positions.cols());
  std::vector<bool> placed(static_cast<std::size_t>(p.cols()), false);
  for (std::size_t i = 0; i < e.instance_count(); ++i) {
    for (int j = 0; j < 3; ++j) {
      const Index v = bundle.render.triangles(j, e.instance_triangle[i]);
      if (placed[v]) continue;
      placed[v] = true;
      const Vec4 b = e.instance_barycentric[i].col(j);
      for (int k = 0; k < 4; ++k) p.col(v) += b[k] * x.col(tets(k, e.instance_tet[i]));
    }
  }
  Matrix3Xd n = Matrix3Xd::Zero(3, p.cols());
  for (Eigen::Index t = 0; t < bundle.render.triangles.cols(); ++t) {
    const auto& tri = bundle.render.triangles.col(t);
    const Vec3 normal = (p.col(tri[1]) - p.col(tri[0])).cross(p.col(tri[2]) - p.col(tri[0]));
    for (int j = 0; j < 3; ++j) n.col(tri[j]) += normal;
  }
  render::PlainMesh mesh;
  for (Eigen::Index v = 0; v < p.cols(); ++v) {
    const Vec3 unit = n.col(v).normalized();
    for (int k = 0; k < 3; ++k) {
      mesh.positions.push_back(static_cast<float>(p(k, v)));
      mesh.normals.push_back(static_cast<float>(unit[k]));
    }
  }
  mesh.triangles.assign(bundle.render.triangles.data(), bundle.render.triangles.data() + bundle.render.triangles.size());
  mesh.color = render::EmbeddedMesh{}.color;
  return mesh;
}

struct RenderPair {
  formats::Image embedded, direct;
};

/// Renders the sphere's world embedded, then the CPU-mapped mesh with the same camera.
RenderPair render_both(const sim::World& world, render::Backend backend = render::Backend::OSMesa) {
  const auto context = render::create_headless_context(backend);
  render::Renderer renderer(kSize, kSize);
  const std::vector<player::BodyAssets> assets{{"sphere.h5", sphere().bundle, 1.0}};
  player::SceneView view(world, assets, renderer);
  // Closer than the view's own framing, which leaves room for motion: the sphere fills
  // most of the frame, so a mismatch has many pixels to show in.
  const Eigen::AlignedBox3f box(Eigen::Vector3f::Constant(0.05f), Eigen::Vector3f::Constant(0.95f));
  renderer.set_camera(render::frame_box(box, render::Vec3f(-0.55f, 0.75f, -0.38f), render::Vec3f::UnitZ(), 35.0f, 1.0f));
  RenderPair out{{kSize, kSize, {}}, {kSize, kSize, {}}};
  renderer.render(out.embedded.rgba);
  const sim::ImplicitIntegrator& body = world.bodies()[0].integrator();
  renderer.set_body_visible(0, false);
  renderer.add_plain(mapped_mesh(sphere().bundle, body.positions(), body.elasticity().tets()));
  renderer.render(out.direct.rgba);
  return out;
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

TEST(Render, OSMesaAndEglDrawTheSameImage) {
  const auto world = sphere().world();
  const RenderPair osmesa = render_both(*world, render::Backend::OSMesa);
  const RenderPair egl = render_both(*world, render::Backend::Egl);
  const testing::ImageDifference d = testing::compare_images(egl.embedded, osmesa.embedded, {.max_abs = 1, .shift = 0});
  EXPECT_EQ(d.failing, 0u);
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
