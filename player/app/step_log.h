#pragma once
/// Observer: one CSV line per step (`run --step-log`): what each phase took and what the
/// step did, for finding what made a step slow. The JSON report holds the means, the p99
/// and the five slowest steps (issue 42); a hitch's neighbours, and how a phase grows
/// over a run (a shatter, then its pile), need every step.
///
/// Streamed through a temporary beside the file, renamed over it when the run ends (also
/// when it ends on a failed step), so a long run holds no more than a line in memory and
/// nobody reads a half-written log.

#include <cstdio>
#include <filesystem>

#include "common/output_file.h"
#include "player/app/run_loop.h"

namespace fissure::player {

class StepLog : public RunObserver {
 public:
  /// Opens the temporary and writes the header; throws fissure::Error naming `path`.
  explicit StepLog(std::filesystem::path path);
  ~StepLog() override;
  StepLog(const StepLog&) = delete;
  StepLog& operator=(const StepLog&) = delete;

  void on_step(const sim::World& world, const sim::StepReport& report, long step) override;
  /// Closes the file and renames it into place; throws fissure::Error if any write failed.
  void on_finish(const sim::World& world, const RunEnd& end) override;

  [[nodiscard]] const std::filesystem::path& path() const { return m_path; }

  /// The columns, in order: the header line's names.
  static constexpr const char* kHeader =
      "step,time_s,step_ms,forces_ms,assembly_ms,solve_ms,fracture_ms,collisions_ms,guard_ms,substeps,"
      "solver_iterations,factorizations,splits,fragments,contacts,responses,response_iterations,"
      "response_sweeps,exact_substeps,energy_halvings,retaken_to_wake";

 private:
  std::filesystem::path m_path;
  TemporaryOutput m_temporary;
  std::FILE* m_file = nullptr;
};

}  // namespace fissure::player
