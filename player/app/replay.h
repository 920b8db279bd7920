#pragma once
/// A recorded run played back (`fissure-player view --replay`): poses the scene's world
/// as the trajectory has it at any recorded frame, forwards or back. Fracture is
/// redone (or undone) split by split exactly as the run did it, so the cracked cage,
/// its exposed faces and fragments are the run's; nodes and projectiles are placed
/// where they were recorded. Nothing is simulated.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "formats/trajectory.h"
#include "player/sim/world.h"

namespace fissure::player {

class Replay {
 public:
  /// `world`: the scene's world as loaded, not yet stepped. Throws fissure::Error,
  /// naming `file`, when the trajectory cannot be replayed in it (another scene, a
  /// version-1 file, inconsistent splits).
  Replay(formats::Trajectory trajectory, std::string file, const sim::World& world);

  /// Poses `world` (the one given to the constructor) at a recorded frame; the frame is
  /// clamped to the last. Throws fissure::Error naming the file and the frame when the
  /// recording does not fit the world.
  void seek(sim::World& world, std::size_t frame);

  [[nodiscard]] std::size_t frame() const { return m_frame; }
  [[nodiscard]] std::size_t frame_count() const { return m_trajectory.time.size(); }
  [[nodiscard]] double time(std::size_t frame) const { return m_trajectory.time[frame]; }
  [[nodiscard]] std::uint64_t step(std::size_t frame) const { return m_trajectory.step[frame]; }
  /// The last frame recorded at or before `time` (the first when none is).
  [[nodiscard]] std::size_t frame_at(double time) const;
  [[nodiscard]] const std::string& file() const { return m_file; }
  /// The splits the world holds now: those recorded up to the current frame.
  [[nodiscard]] std::size_t applied_splits() const { return m_applied; }

 private:
  /// Applies or undoes splits until exactly the first `count` are in the world.
  void apply_splits(sim::World& world, std::size_t count);
  [[noreturn]] void fail(const std::string& what) const;

  formats::Trajectory m_trajectory;
  std::string m_file;
  std::vector<sim::Projectile> m_start_projectiles;  ///< as the scene launches them
  std::size_t m_applied = 0;  ///< the splits in the world: a prefix of m_trajectory.splits
  std::size_t m_frame = 0;
};

}  // namespace fissure::player
