// What the player keeps for rendering: the loaded scene's bundles, and a body's frame
// converted to the renderer's float arrays.
#include <gtest/gtest.h>

#include <fstream>

#include "formats/bundle.h"
#include "formats/scene.h"
#include "player/app/render_frame.h"
#include "player/app/scene_loader.h"
#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"
#include "tests/support/temp_dir.h"
#include "tests/support/two_tet_bundle.h"

namespace fissure::player {
namespace {

TEST(LoadedScene, KeepsEachBodysRenderMeshInstancesAndFaces) {
  testing::TempDir dir;
  const formats::Bundle bundle = testing::two_tet_bundle();
  formats::write_bundle(dir.path() / "two.h5", bundle);
  std::ofstream(dir.path() / "scene.toml") << "[[object]]\nbundle = \"two.h5\"\nscale = 2.0\n"
                                              "translation = [0, 0, 1]\n\n[[object]]\nbundle = \"two.h5\"\n";
  const LoadedScene loaded = load_scene(formats::read_scene(dir.path() / "scene.toml"));
  ASSERT_EQ(loaded.assets.size(), 2u);
  ASSERT_EQ(loaded.world.bodies().size(), 2u);
  for (const BodyAssets& a : loaded.assets) {
    EXPECT_EQ(a.bundle_name, "two.h5");
    EXPECT_EQ(a.bundle.render.positions, bundle.render.positions);  // bundle space: instances are barycentric
    EXPECT_EQ(a.bundle.embedding.instance_tet, bundle.embedding.instance_tet);
    EXPECT_EQ(a.bundle.faces.face_count(), bundle.faces.face_count());
  }
  EXPECT_EQ(loaded.assets[0].scale, 2.0);
  EXPECT_EQ(loaded.assets[1].scale, 1.0);
}

// A render vertex follows a tet that holds it: its triangle is drawn in every tet it
// crosses, clipped to each, so only those tets draw the vertex. Carried by another tet's
// extrapolated coordinates, it went where nothing was drawn once fracture freed that tet
// (issue 42: the sample's "24 mm into the ground" was such a vertex).
TEST(LoadedScene, EachRenderVertexFollowsATetThatHoldsIt) {
  testing::TempDir dir;
  formats::write_bundle(dir.path() / "two.h5", testing::two_tet_bundle());
  std::ofstream(dir.path() / "scene.toml") << "[[object]]\nbundle = \"two.h5\"\n";
  const LoadedScene loaded = load_scene(formats::read_scene(dir.path() / "scene.toml"));
  const sim::EmbeddedPoints& vertices = loaded.world.bodies()[0].vertices;
  ASSERT_EQ(vertices.size(), 3u);
  // Vertex 0 lies in tet 0, vertices 1 and 2 in tet 1 (the triangle's first instance is tet 0's).
  EXPECT_EQ(vertices.tet, (std::vector<TetIndex>{0, 1, 1}));
  for (std::size_t v = 0; v < vertices.size(); ++v) EXPECT_GE(vertices.barycentric[v].minCoeff(), 0.0) << "vertex " << v;
}

TEST(RenderFrame, FollowsTheWorldAndRewritesConnectivityOnlyWhenItChanges) {
  const auto world_ptr = testing::breaking_bar().make();
  sim::World& world = *world_ptr;
  RenderFrame out;
  update_render_frame(world.frame(0), out);
  EXPECT_TRUE(out.topology_changed);  // the first update always writes it
  int rewrites = 0, steps_with_splits = 0;
  for (int i = 0; i < 60; ++i) {
    const sim::StepReport report = world.step();
    update_render_frame(world.frame(0), out);
    ASSERT_EQ(out.topology_changed, !report.splits.empty()) << "step " << i;
    rewrites += out.topology_changed ? 1 : 0;
    steps_with_splits += report.splits.empty() ? 0 : 1;
    const sim::BodyFrame f = world.frame(0);
    ASSERT_EQ(out.positions.size(), 3 * static_cast<std::size_t>(f.positions.cols()));
    ASSERT_EQ(out.tets.size(), 4 * static_cast<std::size_t>(f.tets.cols()));
    for (Eigen::Index k = 0; k < f.positions.size(); k += 17) {
      ASSERT_EQ(out.positions[static_cast<std::size_t>(k)], static_cast<float>(f.positions.data()[k]));
    }
    for (std::size_t k = 0; k < out.tets.size(); ++k) ASSERT_EQ(out.tets[k], f.tets.data()[k]);
    ASSERT_EQ(out.deformation[9 * 5 + 4], static_cast<float>(f.deformation[5](1, 1)));
  }
  EXPECT_GT(steps_with_splits, 0);
  EXPECT_EQ(rewrites, steps_with_splits);
}

}  // namespace
}  // namespace fissure::player
