#pragma once
/// `fissure-player view`: a scene in a window (GLFW) with a Dear ImGui panel. The world
/// runs in real time (or slower), or a fixed number of steps per frame for repeatable
/// runs; the camera orbits, pans and zooms; a click fires a projectile along the view
/// ray; materials, solver settings and drawing features change live. A failed step
/// pauses the world and shows why; the window stays. With a trajectory (--replay), the
/// window plays the recorded run instead, on a timeline to scrub (player/app/replay.h).

#include <filesystem>

#include "formats/scene.h"

namespace fissure::view {

struct ViewOptions {
  int width = 1280, height = 720;           ///< the window [screen pixels]
  long exit_after_frames = 0;               ///< > 0: close after this many frames (tests, demos)
  std::filesystem::path screenshot;         ///< write the last frame's scene (no panel) here at exit
  std::filesystem::path script;             ///< actions to take (view_script.h); empty: none
  int steps_per_frame = 0;                  ///< > 0: exactly this many steps per frame; 0: real time
  bool paused = false;                      ///< start paused
  bool panel = true;                        ///< draw the ImGui panel
  float tessellation = 8.0f;                ///< the relief's level when the panel turns it on
  std::filesystem::path replay;             ///< a trajectory to play back (run --trajectory); empty: simulate
};

/// Returns the exit code: 0, or 1 when the script or a screenshot failed. Throws
/// fissure::Error for invalid input or when no window can be opened.
int view_scene(const formats::Scene& scene, const ViewOptions& options);

}  // namespace fissure::view
