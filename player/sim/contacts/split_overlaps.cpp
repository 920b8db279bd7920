#include "player/sim/contacts/split_overlaps.h"

#include <algorithm>

#include "player/sim/contacts/broad_phase.h"

namespace fissure::sim {

namespace {

bool overlap(const Matrix3Xd& positions, const Matrix4Xu& tets, const EmbeddedPoints& points, Index a, Index b) {
  const Vec3 pa = embedded_position(positions, tets, points, a), pb = embedded_position(positions, tets, points, b);
  return (pa - pb).norm() < points.radius[a] + points.radius[b];
}

}  // namespace

void record_split_overlaps(const Matrix3Xd& positions, const Matrix4Xu& tets, const EmbeddedPoints& points,
                           std::span<const Index> fragment_before, std::span<const Index> fragment_after,
                           SplitOverlaps& overlaps) {
  // Only a piece that came apart can hold a new pair: its points are the candidates
  // (late in a shattering, a few small pieces of hundreds).
  const Index pieces_before = fragment_before.empty() ? 0 : *std::max_element(fragment_before.begin(), fragment_before.end()) + 1;
  constexpr Index kUnseen = kInvalidIndex, kSeveral = kInvalidIndex - 1;
  std::vector<Index> became(pieces_before, kUnseen);  // per piece before: the piece after, or kSeveral
  for (std::size_t t = 0; t < fragment_before.size(); ++t) {
    Index& after = became[fragment_before[t]];
    after = after == kUnseen || after == fragment_after[t] ? fragment_after[t] : kSeveral;
  }
  std::vector<Index> candidate;
  for (std::size_t k = 0; k < points.size(); ++k) {
    if (became[fragment_before[points.tet[k]]] == kSeveral) candidate.push_back(static_cast<Index>(k));
  }
  // The broad phase over the candidates standing still finds the overlapping pairs of
  // different pieces; only those one piece held before are new.
  std::vector<SweptPoint> still(candidate.size());
  std::vector<Index> piece(candidate.size());
  for (std::size_t c = 0; c < candidate.size(); ++c) {
    const Vec3 p = embedded_position(positions, tets, points, candidate[c]);
    still[c] = {p, p, points.radius[candidate[c]]};
    piece[c] = fragment_after[points.tet[candidate[c]]];
  }
  const std::size_t old_size = overlaps.size();
  for (const auto& [body_a, ca, body_b, cb] : self_collision_pairs(std::span(&still, 1), std::span(&piece, 1))) {
    const Index a = candidate[ca], b = candidate[cb];
    if (fragment_before[points.tet[a]] != fragment_before[points.tet[b]]) continue;
    if (overlap(positions, tets, points, a, b)) overlaps.emplace_back(std::min(a, b), std::max(a, b));
  }
  if (overlaps.size() == old_size) return;
  std::sort(overlaps.begin(), overlaps.end());
  overlaps.erase(std::unique(overlaps.begin(), overlaps.end()), overlaps.end());
}

void forget_separated(const Matrix3Xd& positions, const Matrix4Xu& tets, const EmbeddedPoints& points,
                      SplitOverlaps& overlaps) {
  std::erase_if(overlaps, [&](const std::pair<Index, Index>& pair) {
    return !overlap(positions, tets, points, pair.first, pair.second);
  });
}

bool is_split_overlap(const SplitOverlaps& overlaps, Index a, Index b) {
  return std::binary_search(overlaps.begin(), overlaps.end(), std::pair(std::min(a, b), std::max(a, b)));
}

}  // namespace fissure::sim
