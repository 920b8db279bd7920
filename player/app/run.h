#pragma once
/// `fissure-player run`: steps a scene headless through the run loop, prints per-phase
/// timings and a summary, and optionally writes a JSON report, a CSV line per step and
/// an HDF5 trajectory.

#include <filesystem>

#include "formats/scene.h"
#include "player/app/frame_output.h"

namespace fissure::player {

struct RunOptions {
  long steps = 600;
  std::filesystem::path report;      ///< JSON report; empty: none
  std::filesystem::path trajectory;  ///< HDF5 trajectory; empty: none
  std::filesystem::path step_log;    ///< CSV, a line per step (StepLog); empty: none
  long trajectory_every = 1;         ///< record every k-th step
  bool diagnostics = true;           ///< energies and penetrations every step (timed, outside the step)
  bool energy_check = true;          ///< with diagnostics: stop a run that creates energy (Diagnostics)
  FrameOptions images;               ///< frames and video; none: no GL context is made
};

/// Returns the process exit code: 0, or 1 when a step failed (the message names the
/// time, body and reason; the report and trajectory are still written, up to the last
/// good step). Throws fissure::Error for invalid input.
int run_scene(const formats::Scene& scene, const RunOptions& options);

}  // namespace fissure::player
