#pragma once
/// What `fissure-player run` prints and writes when a run ends: the console summary
/// (per-phase timings, energy, fracture, contacts, solver) and the JSON report.

#include <filesystem>
#include <string>
#include <vector>

#include "player/app/diagnostics.h"
#include "player/app/run_statistics.h"

namespace fissure::player {

struct RunRecord {
  std::string scene;                      ///< the scene file's name
  std::vector<std::string> bundles;       ///< per body, its bundle's file name
  double load_seconds = 0;
  const RunStatistics* statistics = nullptr;
  const Diagnostics* diagnostics = nullptr;  ///< null when the run had none
  RunEnd end;
};

/// The console summary, on stdout.
void print_summary(const sim::World& world, const RunRecord& run);

/// The JSON report, written atomically (a temporary beside it, renamed when complete).
/// Throws fissure::Error naming the file when it cannot be written.
void write_report(const std::filesystem::path& path, const sim::World& world, const RunRecord& run);

}  // namespace fissure::player
