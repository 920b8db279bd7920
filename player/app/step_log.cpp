#include "player/app/step_log.h"

#include <cerrno>
#include <cstring>
#include <string>

#include "common/error.h"
#include "player/sim/world.h"

namespace fissure::player {

namespace {

Error write_error(const std::filesystem::path& path, int error) {
  return Error("--step-log " + path.string() + ": cannot write: " + std::strerror(error) + " (nothing was kept)",
               "free space, or give another path");
}

}  // namespace

StepLog::StepLog(std::filesystem::path path) : m_path(std::move(path)), m_temporary(m_path) {
  m_file = std::fopen(m_temporary.path().c_str(), "w");
  if (m_file == nullptr) throw write_error(m_path, errno);
  std::fprintf(m_file, "%s\n", kHeader);
}

StepLog::~StepLog() {
  if (m_file != nullptr) std::fclose(m_file);  // the temporary is removed with m_temporary
}

void StepLog::on_step(const sim::World& world, const sim::StepReport& r, long step) {
  const sim::ContactCounts& c = r.contacts;
  // In kHeader's order: the step and its time, the phases [ms], then the counts.
  std::fprintf(m_file, "%ld,%.9g,", step, world.time());
  std::fprintf(m_file, "%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,", 1e3 * r.total, 1e3 * r.forces, 1e3 * r.assembly,
               1e3 * r.solve, 1e3 * r.fracture, 1e3 * r.collisions, 1e3 * r.guard);
  std::fprintf(m_file, "%d,%d,%d,%zu,%zu,", r.substeps, r.solver_iterations, r.factorizations, r.splits.size(),
               static_cast<std::size_t>(world.fragment_count()));
  std::fprintf(m_file, "%zu,%zu,%zu,%zu,%d,%d,%d\n", c.contacts, c.responses, c.response_iterations,
               c.response_sweeps, r.exact_substeps, r.energy_halvings, r.retaken_to_wake);
}

void StepLog::on_finish(const sim::World& /*world*/, const RunEnd& /*end*/) {
  errno = 0;
  const bool written = std::ferror(m_file) == 0 && std::fflush(m_file) == 0;
  const bool closed = std::fclose(m_file) == 0;
  m_file = nullptr;
  if (!written || !closed) throw write_error(m_path, errno != 0 ? errno : EIO);
  m_temporary.commit();
}

}  // namespace fissure::player
