#pragma once
/// Observer: records node positions every k-th step and every fracture event, and
/// writes them as an HDF5 trajectory (formats/trajectory.h) when the run ends — also
/// when it ends on a failed step, so what led up to a failure can be studied.

#include <filesystem>
#include <string>
#include <vector>

#include "formats/trajectory.h"
#include "player/app/run_loop.h"

namespace fissure::player {

class TrajectoryRecorder : public RunObserver {
 public:
  /// Throws fissure::Error for every < 1.
  TrajectoryRecorder(std::filesystem::path path, std::string scene_name, long every);

  void on_start(const sim::World& world) override;
  void on_step(const sim::World& world, const sim::StepReport& report, long step) override;
  /// Records the last state (if not already recorded) and writes the file.
  void on_finish(const sim::World& world, const RunEnd& end) override;

  [[nodiscard]] std::size_t frame_count() const { return m_trajectory.time.size(); }
  [[nodiscard]] const std::filesystem::path& path() const { return m_path; }

 private:
  void record(const sim::World& world, long step);

  std::filesystem::path m_path;
  long m_every;
  long m_last_recorded = -1;
  formats::Trajectory m_trajectory;
  std::vector<std::vector<NodeIndex>> m_split_from;  ///< per body, per node
};

}  // namespace fissure::player
