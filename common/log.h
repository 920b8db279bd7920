#pragma once
/// Minimal leveled logging to stderr, and a progress reporter for long stages.
/// stdout is left to the commands' own output (tables, JSON), so pipelines can
/// parse it while people still see progress.

#include <chrono>
#include <cstddef>
#include <string>
#include <string_view>

namespace fissure {

enum class LogLevel { Quiet = 0, Warning = 1, Info = 2, Debug = 3 };

void set_log_level(LogLevel level);
LogLevel log_level();

void log_info(std::string_view message);
void log_warning(std::string_view message);
void log_debug(std::string_view message);

/// Times a named stage and logs "stage: X s" at Info level when it ends normally
/// (not while an exception unwinds: a failed stage has no time worth reporting).
class StageTimer {
 public:
  explicit StageTimer(std::string name);
  ~StageTimer();
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

  /// Seconds since construction.
  [[nodiscard]] double elapsed_s() const;

 private:
  std::string m_name;
  std::chrono::steady_clock::time_point m_start;
  int m_exceptions_at_start;
};

}  // namespace fissure
