#include "player/view/view_state.h"

namespace fissure::view {

bool* Features::find(const std::string& name) {
  if (name == "walls") return &walls;
  if (name == "normal-mapping") return &normal_mapping;
  if (name == "tessellation") return &tessellation;
  if (name == "cage") return &cage;
  if (name == "spheres") return &spheres;
  if (name == "replication-colors") return &replication_colors;
  if (name == "fragment-colors") return &fragment_colors;
  return nullptr;
}

void StepHistory::on_step(const sim::World& /*world*/, const sim::StepReport& report, long step) {
  const std::array<double, PhaseCount> seconds{report.forces + report.assembly, report.solve, report.fracture,
                                               report.collisions, report.guard, report.total};
  for (int p = 0; p < PhaseCount; ++p) {
    ms[p].push_back(static_cast<float>(1e3 * seconds[p]));
    if (ms[p].size() > kLength) ms[p].pop_front();
  }
  splits += static_cast<long>(report.splits.size());
  contacts = static_cast<long>(report.contacts.contacts);
  steps = step;
}

}  // namespace fissure::view
