#pragma once
/// Trajectory files: node positions over time and fracture events of a player run, for
/// analysis (h5py, MATLAB). HDF5, written atomically at the end of a run:
///   /time [F] s, /step [F]                       the recorded frames
///   /bodies/<b>/positions [F, N, 3] m             N = the body's final node count; a node
///                                                 that did not exist yet (fracture adds
///                                                 nodes) reads NaN
///   /bodies/<b>/split_from [N]                    the node each added node split from
///                                                 (4294967295 for original nodes)
///   /events/splits/{step, time, body, node, added, normal [S,3], eigenvalue}
///   /events/exposed_faces/{step, body, tet, face}  faces newly on the boundary
/// Root attributes: format "fissure-trajectory", version 1, scene (file name).

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/types.h"

namespace fissure::formats {

struct TrajectoryBody {
  std::string name;
  std::vector<Matrix3Xd> frames;      ///< positions per recorded frame; node count may grow
  std::vector<NodeIndex> split_from;  ///< per node; kInvalidIndex for original nodes
};

struct TrajectorySplit {
  std::uint64_t step = 0;
  double time = 0;
  Index body = 0, node = 0, added = 0;
  Vec3 normal = Vec3::Zero();
  double eigenvalue = 0;
};

struct TrajectoryExposedFace {
  std::uint64_t step = 0;
  Index body = 0, tet = 0;
  std::uint8_t face = 0;
};

struct Trajectory {
  std::string scene;
  std::vector<double> time;
  std::vector<std::uint64_t> step;
  std::vector<TrajectoryBody> bodies;
  std::vector<TrajectorySplit> splits;
  std::vector<TrajectoryExposedFace> exposed_faces;
};

/// Throws fissure::Error naming the file.
void write_trajectory(const std::filesystem::path& path, const Trajectory& trajectory);

}  // namespace fissure::formats
