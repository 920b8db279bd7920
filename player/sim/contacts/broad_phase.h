#pragma once
/// Which embedded points of different pieces (fragments, or bodies) may meet during a
/// step: the self-collision broad phase. Sort and sweep over the points' swept bounds,
/// after a filter that keeps only points overlapping another piece's bounds. (A spatial
/// hash sized by the radius broke down with fine spheres: fast fragments' swept boxes
/// spanned thousands of cells, and 18k spheres took 0.5 s a step.)

#include <limits>
#include <span>
#include <tuple>
#include <vector>

#include "common/types.h"

namespace fissure::sim {

/// A point's motion over the step and its radius.
struct SweptPoint {
  Vec3 start, end;
  double radius;
};

struct AlignedBox {
  Vec3 min = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 max = Vec3::Constant(-std::numeric_limits<double>::infinity());
  void add(const SweptPoint& p) {
    min = min.cwiseMin(Vec3(p.start.cwiseMin(p.end).array() - p.radius));
    max = max.cwiseMax(Vec3(p.start.cwiseMax(p.end).array() + p.radius));
  }
  [[nodiscard]] bool overlaps(const AlignedBox& o) const {
    return (min.array() <= o.max.array()).all() && (o.min.array() <= max.array()).all();
  }
};

/// Two embedded points, (body, point) of each, the first before the second in (body,
/// point) order.
using PointPair = std::tuple<Index, Index, Index, Index>;

/// The pairs of points in different pieces whose swept bounds overlap, sorted, each
/// once. `sweeps[b][k]` is body b's point k; `piece[b][k]` the fragment that holds it.
/// A point with radius 0, a non-finite position or piece kInvalidIndex meets nothing. The result depends
/// only on the input, never on how it was computed. Throws fissure::Error when more
/// than `max_pairs` pairs overlap (bodies piled inside one another), so memory stays
/// bounded.
inline constexpr std::size_t kMaxPointPairs = 4'000'000;
std::vector<PointPair> self_collision_pairs(std::span<const std::vector<SweptPoint>> sweeps,
                                            std::span<const std::vector<Index>> piece,
                                            std::size_t max_pairs = kMaxPointPairs);

}  // namespace fissure::sim
