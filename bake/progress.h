#pragma once
/// Progress of a long bake stage: a line on the log every few seconds, from whichever
/// worker thread notices the time has come. Quiet for stages that end sooner.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <string>

namespace fissure::bake {

class StageProgress {
 public:
  /// `what` names the units counted ("tets"); `total` of them make the stage.
  StageProgress(std::string stage, std::string what, std::size_t total, double every_seconds = 2.0);

  /// Thread-safe. Counts `n` more units done; logs when `every_seconds` have passed.
  void advance(std::size_t n = 1);

 private:
  using Clock = std::chrono::steady_clock;
  std::string m_stage, m_what;
  std::size_t m_total;
  double m_every;
  Clock::time_point m_start;
  std::atomic<std::size_t> m_done{0};
  std::atomic<std::int64_t> m_next_log_ns;
};

}  // namespace fissure::bake
