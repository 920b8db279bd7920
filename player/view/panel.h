#pragma once
/// The viewer's Dear ImGui panel: the clock (pause, step, reset, slow motion), the next
/// shot, per object its material, the solver, the drawing features, and live timings
/// and counters. It edits a PanelState; the viewer applies what it reports changed.

#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "player/sim/world.h"
#include "player/view/view_state.h"

namespace fissure::view {

struct BodyControls {
  std::string name;
  sim::Material material;
  double toughness = 0;  ///< [N]
};

/// A replay's timeline (`view --replay`).
struct ReplayControls {
  std::size_t frames = 0;  ///< 0: not a replay
  int frame = 0;           ///< the frame shown; the slider edits it
  long step = 0;           ///< its step in the recorded run
};

struct PanelState {
  Features features;
  float tessellation_level = 8.0f;
  bool paused = false;
  float time_scale = 1.0f;         ///< simulated seconds per real second (real-time mode)
  int steps_per_frame = 0;         ///< > 0: fixed steps per frame instead of real time
  long pending_steps = 0;          ///< single steps asked for
  bool reset_requested = false, screenshot_requested = false;
  int screenshots = 0, shots = 0;
  std::string screenshot_path;     ///< a script's screenshot, written after the next draw
  bool script_failed = false;
  Shot shot;
  std::vector<BodyControls> bodies;
  sim::WorldSettings settings;
  std::deque<float> render_ms;
  std::string status;              ///< a failure or an error to show
  ReplayControls replay;
};

/// What the user changed this frame.
struct PanelEdits {
  bool features = false, settings = false;
  bool seek = false;                ///< the replay's timeline moved to state.replay.frame
  std::optional<std::size_t> body;  ///< whose material or toughness
};

PanelEdits draw_panel(PanelState& state, const sim::World& world, const StepHistory& history);

}  // namespace fissure::view
