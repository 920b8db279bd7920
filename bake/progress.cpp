#include "bake/progress.h"

#include <cstdio>

#include "common/log.h"

namespace fissure::bake {

StageProgress::StageProgress(std::string stage, std::string what, std::size_t total, double every_seconds)
    : m_stage(std::move(stage)),
      m_what(std::move(what)),
      m_total(total),
      m_every(every_seconds),
      m_start(Clock::now()),
      m_next_log_ns(static_cast<std::int64_t>(every_seconds * 1e9)) {}

void StageProgress::advance(std::size_t n) {
  const std::size_t done = m_done.fetch_add(n, std::memory_order_relaxed) + n;
  const auto elapsed = std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - m_start).count();
  std::int64_t next = m_next_log_ns.load(std::memory_order_relaxed);
  if (elapsed < next) return;
  // One thread wins the right to log this interval.
  if (!m_next_log_ns.compare_exchange_strong(next, elapsed + static_cast<std::int64_t>(m_every * 1e9))) return;
  char line[160];
  std::snprintf(line, sizeof line, "  %s: %zu of %zu %s (%.0f%%) after %.0f s", m_stage.c_str(), done, m_total,
                m_what.c_str(), m_total > 0 ? 100.0 * static_cast<double>(done) / static_cast<double>(m_total) : 100.0,
                static_cast<double>(elapsed) * 1e-9);
  log_info(line);
}

}  // namespace fissure::bake
