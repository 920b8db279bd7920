#pragma once
/// Trajectory files: node positions over time and fracture events of a player run, for
/// analysis (h5py, MATLAB) and for replay (`fissure-player view --replay`). HDF5,
/// written atomically at the end of a run:
///   /time [F] s, /step [F]                       the recorded frames
///   /bodies/<b>/positions [F, N, 3] m             N = the body's final node count; a node
///                                                 that did not exist yet (fracture adds
///                                                 nodes) reads NaN
///   /bodies/<b>/split_from [N]                    the node each added node split from
///                                                 (4294967295 for original nodes)
///   /projectiles/positions [F, P, 3] m            NaN while a projectile is not launched (or
///                                                 did not exist yet)
///   /events/splits/{step, time, body, node, added, normal [S,3], eigenvalue}
///   /events/splits/moved_offsets [S+1], moved_tets [M]
///                                                 split s moved tets moved_tets[offsets[s] ..
///                                                 offsets[s+1]) from `node` to `added`
///   /events/exposed_faces/{step, body, tet, face}  faces newly on the boundary
/// Root attributes: format "fissure-trajectory", version 2, scene (file name).
/// Version 1 lacked the moved tets and the projectiles: it can be read for analysis of
/// positions, not replayed.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/types.h"

namespace fissure::formats {

inline constexpr std::int64_t kTrajectoryVersion = 2;

struct TrajectoryBody {
  std::string name;
  std::vector<Matrix3Xd> frames;      ///< positions per recorded frame; node count may grow (NaN: not yet)
  std::vector<NodeIndex> split_from;  ///< per node; kInvalidIndex for original nodes
};

struct TrajectorySplit {
  std::uint64_t step = 0;
  double time = 0;
  Index body = 0, node = 0, added = 0;
  Vec3 normal = Vec3::Zero();
  double eigenvalue = 0;
  std::vector<TetIndex> moved;  ///< the tets that took `added` in `node`'s place
};

struct TrajectoryExposedFace {
  std::uint64_t step = 0;
  Index body = 0, tet = 0;
  std::uint8_t face = 0;
};

struct Trajectory {
  std::string scene;
  std::int64_t version = kTrajectoryVersion;
  std::vector<double> time;
  std::vector<std::uint64_t> step;
  std::vector<TrajectoryBody> bodies;
  std::vector<Matrix3Xd> projectiles;  ///< per frame, 3×P (P: the last frame's count; NaN: not launched)
  std::vector<TrajectorySplit> splits;
  std::vector<TrajectoryExposedFace> exposed_faces;
};

/// Throws fissure::Error naming the file.
void write_trajectory(const std::filesystem::path& path, const Trajectory& trajectory);

/// Reads and checks a trajectory: shapes agree, frames in step order, splits in step
/// order with node indices in range, no dimension larger than the file can hold.
/// Throws fissure::Error naming the file and the dataset.
Trajectory read_trajectory(const std::filesystem::path& path);

}  // namespace fissure::formats
