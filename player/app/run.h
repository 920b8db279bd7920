#pragma once
/// `fissure-player run`: steps a scene headless, prints per-phase timings and a
/// summary, and optionally writes a JSON report and an HDF5 trajectory.

#include <filesystem>

#include "formats/scene.h"

namespace fissure::player {

struct RunOptions {
  long steps = 600;
  std::filesystem::path report;      ///< JSON report; empty: none
  std::filesystem::path trajectory;  ///< HDF5 trajectory; empty: none
  long trajectory_every = 1;         ///< record every k-th step
};

/// Returns the process exit code. Throws fissure::Error for invalid input.
int run_scene(const formats::Scene& scene, const RunOptions& options);

}  // namespace fissure::player
