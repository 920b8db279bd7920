#include "player/app/trajectory_recorder.h"

#include <algorithm>
#include <limits>

#include "common/error.h"

namespace fissure::player {

namespace {

/// A projectile not launched yet is not in the scene (formats/trajectory.h).
constexpr double kNotThere = std::numeric_limits<double>::quiet_NaN();

}  // namespace

TrajectoryRecorder::TrajectoryRecorder(std::filesystem::path path, std::string scene_name, long every)
    : m_path(std::move(path)), m_every(every) {
  if (every < 1) {
    throw Error("--trajectory-every " + std::to_string(every) + " is below 1", "record every k-th step with k ≥ 1");
  }
  m_trajectory.scene = std::move(scene_name);
}

void TrajectoryRecorder::on_start(const sim::World& world) {
  m_trajectory.bodies.resize(world.bodies().size());
  m_split_from.resize(world.bodies().size());
  for (std::size_t b = 0; b < world.bodies().size(); ++b) {
    m_trajectory.bodies[b].name = world.bodies()[b].name;
    m_split_from[b].assign(world.bodies()[b].integrator().node_count(), kInvalidIndex);
  }
  record(world, 0);
}

void TrajectoryRecorder::record(const sim::World& world, long step) {
  m_trajectory.time.push_back(world.time());
  m_trajectory.step.push_back(static_cast<std::uint64_t>(step));
  for (std::size_t b = 0; b < world.bodies().size(); ++b) {
    m_trajectory.bodies[b].frames.push_back(world.bodies()[b].integrator().positions());
  }
  Matrix3Xd& projectiles = m_trajectory.projectiles.emplace_back(3, static_cast<Eigen::Index>(world.projectiles().size()));
  for (std::size_t j = 0; j < world.projectiles().size(); ++j) {
    const sim::Projectile& p = world.projectiles()[j];
    projectiles.col(static_cast<Eigen::Index>(j)) = p.launched ? p.position : Vec3::Constant(kNotThere);
  }
  m_last_recorded = step;
}

void TrajectoryRecorder::on_step(const sim::World& world, const sim::StepReport& report, long step) {
  const auto at = static_cast<std::uint64_t>(step);
  for (const auto& [body, split] : report.splits) {
    std::vector<NodeIndex>& from = m_split_from[body];
    from.resize(std::max<std::size_t>(from.size(), split.added + 1), kInvalidIndex);
    from[split.added] = split.node;
    m_trajectory.splits.push_back(
        {at, world.time(), body, split.node, split.added, split.normal, split.eigenvalue, split.moved});
  }
  for (const auto& [body, face] : report.exposed) {
    m_trajectory.exposed_faces.push_back({at, body, face.tet, static_cast<std::uint8_t>(face.face)});
  }
  if (step % m_every == 0) record(world, step);
}

void TrajectoryRecorder::on_finish(const sim::World& world, const RunEnd& end) {
  if (m_last_recorded != end.steps) record(world, end.steps);
  for (std::size_t b = 0; b < world.bodies().size(); ++b) {
    m_split_from[b].resize(world.bodies()[b].integrator().node_count(), kInvalidIndex);
    m_trajectory.bodies[b].split_from = m_split_from[b];
  }
  formats::write_trajectory(m_path, m_trajectory);
}

}  // namespace fissure::player
