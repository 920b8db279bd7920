#include "common/log.h"

#include <atomic>
#include <cstdio>
#include <exception>

namespace fissure {
namespace {
std::atomic<LogLevel> g_level{LogLevel::Info};

void emit(LogLevel level, std::string_view prefix, std::string_view message) {
  if (static_cast<int>(level) > static_cast<int>(g_level.load())) return;
  std::fprintf(stderr, "%.*s%.*s\n", static_cast<int>(prefix.size()), prefix.data(),
               static_cast<int>(message.size()), message.data());
}
}  // namespace

void set_log_level(LogLevel level) { g_level = level; }
LogLevel log_level() { return g_level.load(); }

void log_info(std::string_view message) { emit(LogLevel::Info, "", message); }
void log_warning(std::string_view message) { emit(LogLevel::Warning, "warning: ", message); }
void log_debug(std::string_view message) { emit(LogLevel::Debug, "debug: ", message); }

StageTimer::StageTimer(std::string name)
    : m_name(std::move(name)),
      m_start(std::chrono::steady_clock::now()),
      m_exceptions_at_start(std::uncaught_exceptions()) {
  log_debug(m_name + ": started");
}

StageTimer::~StageTimer() {
  if (std::uncaught_exceptions() > m_exceptions_at_start) return;
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, ": %.3f s", elapsed_s());
  log_info(m_name + buffer);
}

double StageTimer::elapsed_s() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
}

}  // namespace fissure
