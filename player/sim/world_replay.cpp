// World posed, not stepped (player/app/replay.h): splits redone and undone exactly as a
// recorded run made them, nodes and projectiles placed where it recorded them.
#include <algorithm>

#include "common/assert.h"
#include "common/error.h"
#include "player/sim/world.h"

namespace fissure::sim {

void World::redo_splits(Index body, std::span<const RecordedSplit> splits) {
  Body& b = m_bodies.at(body);
  const Matrix4Xu& tets = b.integrator().elasticity().tets();
  // Check the whole batch first: the table after the earlier splits of the batch.
  Matrix4Xu after = tets;
  NodeIndex next = b.integrator().node_count();
  for (const RecordedSplit& s : splits) {
    const bool fits = s.node < next && s.added == next && !s.moved.empty();
    if (!fits) {
      throw Error("body '" + b.name + "': the recorded split of node " + std::to_string(s.node) + " into " +
                      std::to_string(s.added) + " does not fit its " + std::to_string(next) + " nodes",
                  "replay a trajectory with the scene that recorded it");
    }
    for (const TetIndex t : s.moved) {
      Index* corner = static_cast<Eigen::Index>(t) < after.cols() ? std::find(after.col(t).data(), after.col(t).data() + 4, s.node) : nullptr;
      if (corner == nullptr || corner == after.col(t).data() + 4) {
        throw Error("body '" + b.name + "': the recorded split of node " + std::to_string(s.node) + " moves tet " +
                        std::to_string(t) + ", which does not hold it",
                    "replay a trajectory with the scene that recorded it");
      }
      *corner = s.added;
    }
    ++next;
  }
  std::vector<std::pair<TetIndex, int>> slots;
  std::vector<TetFace> exposed;
  for (const RecordedSplit& s : splits) {
    slots.clear();
    for (const TetIndex t : s.moved) {
      const auto column = tets.col(t);
      slots.emplace_back(t, static_cast<int>(std::find(column.data(), column.data() + 4, s.node) - column.data()));
    }
    const NodeIndex added = b.integrator().split_node(s.node, slots);
    b.topology.on_split(s.node, added, slots, tets, exposed);
    m_previous_positions[body].conservativeResize(Eigen::NoChange, added + 1);
    m_previous_positions[body].col(added) = m_previous_positions[body].col(s.node);
  }
  if (!splits.empty()) b.topology.update_fragments(tets);
  m_deformation_step[body] = 0;
}

void World::undo_splits(Index body, std::span<const RecordedSplit> splits) {
  Body& b = m_bodies.at(body);
  for (auto s = splits.rbegin(); s != splits.rend(); ++s) {
    FISSURE_ASSERT(s->added + 1 == b.integrator().node_count());
    b.integrator().undo_split(s->node, s->added);
    b.topology.undo_split(s->node, s->added, b.integrator().elasticity().tets());
    m_previous_positions[body].conservativeResize(Eigen::NoChange, s->added);
  }
  if (!splits.empty()) b.topology.update_fragments(b.integrator().elasticity().tets());
  m_deformation_step[body] = 0;
}

void World::pose(Index body, const Matrix3Xd& positions) {
  ImplicitIntegrator& integrator = m_bodies.at(body).integrator();
  integrator.set_positions(positions);
  integrator.set_velocities(Matrix3Xd::Zero(3, integrator.node_count()));
  m_previous_positions[body] = positions;
  m_deformation_step[body] = 0;
}

void World::pose(double time, std::span<const Projectile> projectiles) {
  FISSURE_ASSERT(projectiles.size() == m_projectiles.size());
  m_time = time;
  std::copy(projectiles.begin(), projectiles.end(), m_projectiles.begin());
}

}  // namespace fissure::sim
