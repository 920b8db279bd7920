// The viewer's parts that need no window: the orbit camera's geometry and the script
// reader's errors.
#include <gtest/gtest.h>

#include <cmath>

#include "common/error.h"
#include "player/view/orbit_camera.h"
#include "player/view/view_script.h"

namespace fissure {
namespace {

using render::Vec3f;

render::Camera oblique_camera() {
  render::Camera c;
  c.eye = Vec3f(2.0f, -3.0f, 1.5f);
  c.target = Vec3f(0.2f, 0.1f, 0.3f);
  c.up = Vec3f::UnitZ();
  c.fov_y_degrees = 35.0f;
  return c;
}

TEST(OrbitCamera, TakesOverTheCameraItIsGivenUnchanged) {
  const render::Camera c = oblique_camera();
  const render::Camera same = view::OrbitCamera(c).camera();
  EXPECT_LT((same.eye - c.eye).norm(), 1e-5f);
  EXPECT_LT((same.target - c.target).norm(), 1e-6f);
  EXPECT_FLOAT_EQ(same.near_plane, c.near_plane);
}

TEST(OrbitCamera, OrbitKeepsTheDistanceAndTheUpAxisZoomScalesIt) {
  const render::Camera c = oblique_camera();
  view::OrbitCamera orbit(c);
  orbit.orbit(120.0f, -40.0f);
  const render::Camera turned = orbit.camera();
  const float distance = (c.eye - c.target).norm();
  EXPECT_NEAR((turned.eye - turned.target).norm(), distance, 1e-5f * distance);
  EXPECT_GT((turned.eye - c.eye).norm(), 0.1f);
  EXPECT_EQ(turned.up, Vec3f::UnitZ());
  // Pitch stops short of the pole, however far the mouse goes.
  orbit.orbit(0.0f, 1e5f);
  const render::Camera top = orbit.camera();
  EXPECT_LT((top.eye - top.target).normalized().z(), 0.9999f);
  orbit.zoom(1.0f);
  EXPECT_NEAR((orbit.camera().eye - orbit.camera().target).norm(), 0.9f * distance, 1e-4f * distance);
}

TEST(OrbitCamera, PanMovesEyeAndTargetAcrossTheView) {
  const render::Camera c = oblique_camera();
  view::OrbitCamera orbit(c);
  orbit.pan(50.0f, 20.0f, 480);
  const render::Camera moved = orbit.camera();
  const Vec3f shift = moved.target - c.target;
  EXPECT_GT(shift.norm(), 1e-3f);
  EXPECT_LT(std::abs(shift.dot((c.target - c.eye).normalized())), 1e-5f) << "panning must not move along the view";
  EXPECT_LT(((moved.eye - c.eye) - shift).norm(), 1e-5f);
}

TEST(OrbitCamera, TheRayThroughTheCentrePixelGoesToTheTargetAndCornersSpanTheFieldOfView) {
  const render::Camera c = oblique_camera();
  const view::OrbitCamera orbit(c);
  // An odd size has a centre pixel.
  const view::Ray centre = orbit.ray(160.0f, 120.0f, 321, 241);
  EXPECT_LT((centre.direction - (c.target - c.eye).normalized()).norm(), 1e-5f);
  EXPECT_LT((centre.origin - c.eye).norm(), 1e-5f);
  // The top row's centre ray is half the vertical field of view above the axis (less half a pixel).
  const view::Ray top = orbit.ray(160.0f, -0.5f, 321, 241);
  const float angle = std::acos(top.direction.dot(centre.direction)) * 180.0f / 3.14159265f;
  EXPECT_NEAR(angle, 17.5f, 1e-3f);
  EXPECT_GT(top.direction.z(), centre.direction.z());
}

TEST(ViewScript, ReadsEveryAction) {
  const auto actions = view::parse_script(
      "# a test\n\nwait 3\npause\nstep 2\nfire 10 20.5\ntoggle walls  # comment\nset bunny toughness 4.5\n"
      "screenshot out.png\nresume\nquit\nshot 2 0.1 30\n",
      "s.txt");
  ASSERT_EQ(actions.size(), 10u);
  using Kind = view::ScriptAction::Kind;
  EXPECT_EQ(actions[0].kind, Kind::Wait);
  EXPECT_EQ(actions[0].count, 3);
  EXPECT_EQ(actions[0].line, 3);
  EXPECT_EQ(actions[3].kind, Kind::Fire);
  EXPECT_FLOAT_EQ(actions[3].y, 20.5f);
  EXPECT_EQ(actions[4].name, "walls");
  EXPECT_EQ(actions[5].name, "bunny");
  EXPECT_EQ(actions[5].parameter, "toughness");
  EXPECT_DOUBLE_EQ(actions[5].value, 4.5);
  EXPECT_EQ(actions[6].name, "out.png");
  EXPECT_EQ(actions[8].kind, Kind::Quit);
  EXPECT_EQ(actions[9].kind, Kind::Shot);
  EXPECT_FLOAT_EQ(actions[9].speed, 30.0f);
}

TEST(ViewScript, ErrorsNameTheFileTheLineAndTheChoices) {
  const auto message = [](const std::string& text) {
    try {
      view::parse_script(text, "s.txt");
    } catch (const Error& e) {
      return std::string(e.what()) + " | " + e.hint();
    }
    return std::string("no error");
  };
  EXPECT_NE(message("wait 1\njump 3\n").find("s.txt:2: unknown action 'jump'"), std::string::npos);
  EXPECT_NE(message("toggle wallz\n").find("toggle one of: walls"), std::string::npos);
  EXPECT_NE(message("set bunny hardness 3\n").find("no parameter 'hardness'"), std::string::npos);
  EXPECT_NE(message("fire 10\n").find("s.txt:1: expected a pixel's y"), std::string::npos);
  EXPECT_NE(message("wait 0\n").find("out of range"), std::string::npos);
  EXPECT_NE(message("step 2 3\n").find("unexpected '3'"), std::string::npos);
  EXPECT_NE(message("fire nan 3\n").find("expected a pixel's x"), std::string::npos);
  EXPECT_THROW(view::read_script("/no/such/script.txt"), Error);
}

}  // namespace
}  // namespace fissure
