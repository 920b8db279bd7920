#include "player/app/replay.h"

#include <algorithm>

#include "common/error.h"

namespace fissure::player {

namespace {

constexpr const char* kHint = "replay a trajectory with the scene that recorded it (fissure-player run --trajectory)";

}  // namespace

Replay::Replay(formats::Trajectory trajectory, std::string file, const sim::World& world)
    : m_trajectory(std::move(trajectory)), m_file(std::move(file)), m_start_projectiles(world.projectiles()) {
  if (m_trajectory.version < 2) {
    fail("was recorded by an older player (trajectory version " + std::to_string(m_trajectory.version) +
         ") that did not keep what a replay needs");
  }
  if (m_trajectory.time.empty()) fail("holds no frames");
  const auto& bodies = world.bodies();
  if (m_trajectory.bodies.size() != bodies.size()) {
    fail("has " + std::to_string(m_trajectory.bodies.size()) + " bodies; the scene has " + std::to_string(bodies.size()));
  }
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const formats::TrajectoryBody& recorded = m_trajectory.bodies[b];
    const Index nodes = bodies[b].integrator().node_count();
    const auto original = static_cast<std::size_t>(
        std::count(recorded.split_from.begin(), recorded.split_from.end(), kInvalidIndex));
    if (recorded.name != bodies[b].name || original != nodes) {
      fail("body " + std::to_string(b) + " is '" + recorded.name + "' with " + std::to_string(original) +
           " nodes; the scene's is '" + bodies[b].name + "' with " + std::to_string(nodes));
    }
  }
  const Eigen::Index projectiles = m_trajectory.projectiles.empty() ? 0 : m_trajectory.projectiles[0].cols();
  if (projectiles != static_cast<Eigen::Index>(world.projectiles().size())) {
    fail("has " + std::to_string(projectiles) + " projectiles; the scene has " + std::to_string(world.projectiles().size()));
  }
}

void Replay::fail(const std::string& what) const { throw Error(m_file + ": " + what, kHint); }

std::size_t Replay::frame_at(double time) const {
  const auto& t = m_trajectory.time;
  const auto after = std::upper_bound(t.begin(), t.end(), time);
  return after == t.begin() ? 0 : static_cast<std::size_t>(after - t.begin()) - 1;
}

void Replay::apply_splits(sim::World& world, std::size_t count) {
  const auto& splits = m_trajectory.splits;
  const auto range = [&](std::size_t from, std::size_t to, Index body) {
    std::vector<sim::RecordedSplit> out;
    for (std::size_t i = from; i < to; ++i) {
      if (splits[i].body == body) out.push_back({splits[i].node, splits[i].added, splits[i].moved});
    }
    return out;
  };
  // Each body's batch is checked before it changes; a later body's failure leaves the
  // earlier ones split, which is why the viewer seeks to the end and back once at load
  // (a trajectory that does not fit fails there, before anything is shown).
  for (Index b = 0; b < world.bodies().size(); ++b) {
    if (count > m_applied) {
      try {
        world.redo_splits(b, range(m_applied, count, b));
      } catch (const Error& e) {
        fail(e.what());
      }
    } else if (count < m_applied) {
      world.undo_splits(b, range(count, m_applied, b));
    }
  }
  m_applied = count;
}

void Replay::seek(sim::World& world, std::size_t frame) {
  frame = std::min(frame, frame_count() - 1);
  const std::uint64_t step = m_trajectory.step[frame];
  const auto& splits = m_trajectory.splits;
  const auto done = std::partition_point(splits.begin(), splits.end(), [&](const auto& s) { return s.step <= step; });
  apply_splits(world, static_cast<std::size_t>(done - splits.begin()));
  for (Index b = 0; b < world.bodies().size(); ++b) {
    const Matrix3Xd& recorded = m_trajectory.bodies[b].frames[frame];
    const Eigen::Index nodes = world.bodies()[b].integrator().node_count();
    if (recorded.cols() < nodes || !recorded.leftCols(nodes).allFinite()) {
      fail("frame " + std::to_string(frame) + " has no finite position for every node of body '" +
           world.bodies()[b].name + "'");
    }
    world.pose(b, recorded.leftCols(nodes));
  }
  std::vector<sim::Projectile> projectiles = m_start_projectiles;
  for (std::size_t j = 0; j < projectiles.size(); ++j) {
    const Vec3 recorded = m_trajectory.projectiles[frame].col(static_cast<Eigen::Index>(j));
    projectiles[j].launched = recorded.allFinite();  // NaN: not launched yet, still where it starts
    if (projectiles[j].launched) projectiles[j].position = recorded;
  }
  world.pose(m_trajectory.time[frame], projectiles);
  m_frame = frame;
}

}  // namespace fissure::player
