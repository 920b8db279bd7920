// `fissure-player view` end to end, in a real window under Xvfb (Debian `xvfb`): its
// screenshot against the headless render of the same step, scripted shots and toggles,
// and the errors a user meets.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>

#include "bake/bake.h"
#include "formats/bundle.h"
#include "formats/image.h"
#include "tests/support/image_compare.h"
#include "tests/support/procedural.h"
#include "tests/support/run_command.h"
#include "tests/support/temp_dir.h"
#include "tests/support/virtual_display.h"

namespace fissure {
namespace {

using testing::quoted;

constexpr const char* kSize = "160x120";

testing::CommandResult in_window(const std::string& arguments) {
  return testing::run_command(testing::VirtualDisplay::shared().env_prefix() + FISSURE_PLAYER_EXE + " " + arguments);
}

/// A breakable sphere of 1,280 triangles in a 4³-cube cage, resting on the ground.
class ViewCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    bake::BakeOptions options;
    const formats::Bundle bundle = bake::embed(testing::icosphere(3, 0.4, Vec3(0.5, 0.5, 0.5)),
                                               testing::grid_cage(Vec3(0, 0, 0), Vec3(1, 1, 1), 4, 4, 4), options,
                                               "icosphere", "grid");
    formats::write_bundle(bundle_path(), bundle);
  }
  static std::filesystem::path bundle_path() {
    static const testing::TempDir shared;
    return shared.path() / "sphere.h5";
  }
  void SetUp() override {
    // The README's test command installs Xvfb: without it the setup is broken, not the test.
    ASSERT_TRUE(testing::VirtualDisplay::shared().available())
        << "Xvfb did not start: run scripts/install-deps.sh (Debian's xvfb)";
  }

  /// The scene, with `material_keys` added to the ball's material.
  std::filesystem::path scene(const std::string& material_keys = "") {
    const std::filesystem::path path = dir.path() / "scene.toml";
    std::ofstream(path) << "[solver]\ndt = 0.004\n\n[features]\nfracture = true\n\n[environment.ground]\n\n[[object]]\nname = \"ball\"\n"
                        << "bundle = " << quoted(bundle_path()) << "\ntranslation = [0, 0, 0.2]\n\n"
                        << "[object.material]\nyoungs_modulus = 2e4\npoisson_ratio = 0.3\ndensity = 500\n"
                        << material_keys << "\n";
    return path;
  }
  std::filesystem::path script(const std::string& text) {
    const std::filesystem::path path = dir.path() / "actions.txt";
    std::ofstream(path) << text;
    return path;
  }
  /// `view` with the script, fixed steps, no panel; returns its result.
  testing::CommandResult view(const std::string& material_keys, const std::string& actions, int frames) {
    return in_window("view " + quoted(scene(material_keys)) + " --size " + kSize + " --no-panel --steps-per-frame 1" +
                     " --exit-after-frames " + std::to_string(frames) + " --script " + quoted(script(actions)));
  }
  static long fragments(const std::string& output) {
    std::smatch match;
    const std::regex summary(R"(view +\d+ frames, \d+ steps, t = [0-9.]+ s, (\d+) fragments)");
    return std::regex_search(output, match, summary) ? std::stol(match[1]) : -1;
  }

  testing::TempDir dir;
};

TEST_F(ViewCli, TheScreenshotMatchesTheHeadlessRenderOfTheSameStep) {
  const auto shot = dir.path() / "shot.png", frames = dir.path() / "frames";
  const auto viewed = in_window("view " + quoted(scene()) + " --size " + kSize +
                                " --steps-per-frame 1 --exit-after-frames 12 --screenshot " + quoted(shot));
  ASSERT_EQ(viewed.exit_code, 0) << viewed.output;
  EXPECT_NE(viewed.output.find("12 frames, 12 steps"), std::string::npos) << viewed.output;
  // dt = 0.004 s and 250 frames/s: headless frame 12 is the state after 12 steps.
  const auto headless = testing::run_command(std::string(FISSURE_PLAYER_EXE) + " run " + quoted(scene()) +
                                             " --steps 12 --fps 250 --size " + kSize + " --frames " + quoted(frames));
  ASSERT_EQ(headless.exit_code, 0) << headless.output;
  const formats::Image window = formats::read_png(shot), offscreen = formats::read_png(frames / "frame-00012.png");
  const testing::ImageDifference d = testing::compare_images(window, offscreen, {});
  EXPECT_LE(d.fraction(), 1e-3) << d.failing << " pixels differ";
  std::size_t foreground = 0;
  for (std::size_t i = 0; i < window.rgba.size(); i += 4) foreground += window.rgba[i] != window.rgba[0];
  EXPECT_GT(foreground, window.rgba.size() / 4 / 20) << "the ball should fill part of the frame";
}

TEST_F(ViewCli, AShotThroughTheMiddleBreaksTheBallAndNothingElseDoes) {
  const std::string breakable = "toughness = 0.5\n";
  const auto quiet = view(breakable, "wait 40\n", 40);
  ASSERT_EQ(quiet.exit_code, 0) << quiet.output;
  EXPECT_EQ(fragments(quiet.output), 1) << quiet.output;
  const auto hit = view(breakable, "set ball density 500\nshot 5 0.08 60\nfire 80 60\nwait 40\n", 40);
  ASSERT_EQ(hit.exit_code, 0) << hit.output;
  EXPECT_GT(fragments(hit.output), 1) << hit.output;
  EXPECT_NE(hit.output.find("1 shots"), std::string::npos) << hit.output;
}

TEST_F(ViewCli, TogglingWallsChangesTheImageOnlyWhereFractureOpenedFaces) {
  const auto a = dir.path() / "a.png", b = dir.path() / "b.png", c = dir.path() / "c.png";
  const std::string shots = "screenshot " + a.string() + "\ntoggle walls\nscreenshot " + b.string() +
                            "\ntoggle walls\nscreenshot " + c.string() + "\n";
  // Unbroken: no wall anywhere, so walls off changes nothing.
  auto result = view("", "pause\n" + shots, 8);
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_EQ(formats::read_png(a).rgba, formats::read_png(b).rgba);
  // Broken by a shot: walls off shows the cracks' insides; on again, the same image.
  result = view("toughness = 0.5\n", "shot 5 0.08 60\nfire 80 60\nwait 30\npause\n" + shots, 45);
  ASSERT_EQ(result.exit_code, 0) << result.output;
  ASSERT_GT(fragments(result.output), 1) << result.output;
  EXPECT_NE(formats::read_png(a).rgba, formats::read_png(b).rgba);
  EXPECT_EQ(formats::read_png(a).rgba, formats::read_png(c).rgba);
}

// A run recorded headless, replayed in the window: each scrubbed frame is the headless
// frame of its step, with walls and without, whichever way the timeline moves.
TEST_F(ViewCli, AReplayShowsTheRecordedRunsFramesWithAndWithoutWalls) {
  const std::string hit =
      "toughness = 0.5\n\n[[projectile]]\nradius = 0.08\nmass = 5\nposition = [0.5, 0.5, 1.3]\nvelocity = [0, 0, -60]\n";
  const auto scene_file = scene(hit), trajectory = dir.path() / "run.h5";
  const auto walls = dir.path() / "walls", bare = dir.path() / "bare";
  // dt = 0.004 s and 250 frames/s: headless frame k is the state after k steps.
  const std::string run = std::string(FISSURE_PLAYER_EXE) + " run " + quoted(scene_file) +
                          " --steps 40 --fps 250 --size " + kSize + " --frames ";
  auto result = testing::run_command(run + quoted(walls) + " --trajectory " + quoted(trajectory) + " --trajectory-every 2");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  result = testing::run_command(run + quoted(bare) + " --no-walls");
  ASSERT_EQ(result.exit_code, 0) << result.output;

  const auto a = dir.path() / "a.png", b = dir.path() / "b.png", c = dir.path() / "c.png", d = dir.path() / "d.png";
  const std::string actions = "seek 20\nscreenshot " + a.string() + "\ntoggle walls\nscreenshot " + b.string() +
                              "\nseek 5\nscreenshot " + c.string() + "\ntoggle walls\nseek 20\nscreenshot " +
                              d.string() + "\nquit\n";
  result = in_window("view " + quoted(scene_file) + " --replay " + quoted(trajectory) + " --size " + kSize +
                     " --paused --no-panel --script " + quoted(script(actions)));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("replay     frame 20 of 21 (step 40)"), std::string::npos) << result.output;
  ASSERT_GT(fragments(result.output), 1) << "the shot should break the ball by step 40\n" << result.output;
  const auto matches = [](const std::filesystem::path& window, const std::filesystem::path& headless) {
    const testing::ImageDifference diff = testing::compare_images(formats::read_png(window), formats::read_png(headless), {});
    EXPECT_LE(diff.fraction(), 1e-3) << window.filename() << " against " << headless << ": " << diff.failing << " pixels differ";
  };
  matches(a, walls / "frame-00040.png");
  matches(b, bare / "frame-00040.png");
  matches(c, bare / "frame-00010.png");
  EXPECT_EQ(formats::read_png(a).rgba, formats::read_png(d).rgba) << "back and forth on the timeline changed frame 20";
  EXPECT_NE(formats::read_png(a).rgba, formats::read_png(b).rgba) << "a broken ball shows walls";
}

TEST_F(ViewCli, AReplayRefusesShotsAndEditsAndAnotherScenesTrajectory) {
  const auto trajectory = dir.path() / "run.h5";
  auto result = testing::run_command(std::string(FISSURE_PLAYER_EXE) + " -q run " + quoted(scene()) +
                                     " --steps 4 --no-render --trajectory " + quoted(trajectory));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const std::string replay = "view " + quoted(scene()) + " --replay " + quoted(trajectory) + " --size " + kSize +
                             " --no-panel --exit-after-frames 5 --script ";
  result = in_window(replay + quoted(script("set ball toughness 3\n")));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("actions.txt:1: a replay's materials are the recorded run's"), std::string::npos)
      << result.output;
  result = in_window(replay + quoted(script("fire 80 60\nwait 2\n")));
  EXPECT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("0 shots"), std::string::npos) << result.output;
  // Another scene: a second ball the recording does not have.
  const auto other = dir.path() / "other.toml";
  std::ofstream(other) << std::ifstream(scene()).rdbuf() << "\n[[object]]\nname = \"ball2\"\nbundle = "
                       << quoted(bundle_path()) << "\ntranslation = [2, 0, 0.2]\n";
  result = in_window("view " + quoted(other) + " --replay " + quoted(trajectory) + " --exit-after-frames 2");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("run.h5: has 1 bodies; the scene has 2"), std::string::npos) << result.output;
  // Not a trajectory at all.
  result = in_window("view " + quoted(scene()) + " --replay " + quoted(bundle_path()) + " --exit-after-frames 2");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("not a Fissure trajectory"), std::string::npos) << result.output;
}

TEST_F(ViewCli, ScriptErrorsNameTheLineAndExitOne) {
  auto result = view("", "wait 2\nset nobody toughness 3\n", 10);
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("actions.txt:2: the scene has no object named 'nobody'"), std::string::npos)
      << result.output;
  result = view("", "explode\n", 10);
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("actions.txt:1: unknown action 'explode'"), std::string::npos) << result.output;
  result = view("", "set ball poisson_ratio 0.7\n", 10);
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("oisson"), std::string::npos) << result.output;
}

TEST(ViewWithoutDisplay, SaysToUseRunFrames) {
  const auto result = testing::run_command("env -u DISPLAY -u WAYLAND_DISPLAY " + std::string(FISSURE_PLAYER_EXE) +
                                           " view no-such-scene-needed.toml");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  // The scene is read first: a missing scene is named before the display is looked for.
  EXPECT_NE(result.output.find("no-such-scene-needed.toml"), std::string::npos) << result.output;
}

}  // namespace
}  // namespace fissure
