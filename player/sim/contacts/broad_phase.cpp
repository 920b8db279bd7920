#include "player/sim/contacts/broad_phase.h"

#include <algorithm>
#include <map>
#include <string>

#include "common/counting_sort.h"
#include "common/error.h"

namespace fissure::sim {

namespace {

struct Piece {
  Index body, fragment;
  bool operator<(const Piece& o) const { return std::tie(body, fragment) < std::tie(o.body, o.fragment); }
};

struct Candidate {
  AlignedBox box;
  Index body, point, piece;  // piece: index into the pieces' list
};

/// Past this many pieces (a shattered body) the per-point filter would cost more than
/// it saves: every point goes to the sweep.
constexpr std::size_t kMaxFilteredPieces = 64;

/// 1. Each piece's bounds; then the points that overlap another piece's bounds.
std::vector<Candidate> candidates_near_other_pieces(std::span<const std::vector<SweptPoint>> sweeps,
                                                    std::span<const std::vector<Index>> piece) {
  const auto placeable = [&](Index bi, Index k) {
    const SweptPoint& p = sweeps[bi][k];
    return p.radius > 0.0 && p.start.allFinite() && p.end.allFinite() && piece[bi][k] != kInvalidIndex;
  };
  std::map<Piece, AlignedBox> piece_bounds;
  for (Index bi = 0; bi < sweeps.size(); ++bi) {
    for (Index k = 0; k < sweeps[bi].size(); ++k) {
      if (placeable(bi, k)) piece_bounds[{bi, piece[bi][k]}].add(sweeps[bi][k]);
    }
  }
  const std::vector<std::pair<Piece, AlignedBox>> pieces(piece_bounds.begin(), piece_bounds.end());
  const bool filter = pieces.size() <= kMaxFilteredPieces;
  std::vector<Candidate> candidates;
  for (Index bi = 0; bi < sweeps.size(); ++bi) {
    for (Index k = 0; k < sweeps[bi].size(); ++k) {
      if (!placeable(bi, k)) continue;
      Candidate c{{}, bi, k, 0};
      c.box.add(sweeps[bi][k]);
      const Piece own{bi, piece[bi][k]};
      c.piece = static_cast<Index>(
          std::lower_bound(pieces.begin(), pieces.end(), own, [](const auto& e, const Piece& p) { return e.first < p; }) -
          pieces.begin());
      const bool near_another = !filter || std::any_of(pieces.begin(), pieces.end(), [&](const auto& other) {
        return &other != &pieces[c.piece] && c.box.overlaps(other.second);
      });
      if (near_another) candidates.push_back(c);
    }
  }
  return candidates;
}

/// Bodies piled into one another (a scene placing many objects at one spot) make every
/// point meet every other: the pairs, and the contacts made from them, would grow with
/// the square of the points until memory runs out (issue 46). Past the limit the step
/// stops with an error that says how many bodies and points were involved.
[[noreturn]] void throw_too_many_pairs(const std::vector<Candidate>& candidates, std::size_t max_pairs) {
  Index bodies = 0;
  for (const Candidate& c : candidates) bodies = std::max(bodies, c.body + 1);
  throw Error("collision: more than " + std::to_string(max_pairs) + " pairs of collision spheres overlap at once (" +
                  std::to_string(candidates.size()) + " spheres of up to " + std::to_string(bodies) +
                  " bodies are near one another): the bodies are piled inside each other",
              "place the objects apart from one another in the scene (translation), or use fewer of them");
}

/// Sorts distinct pairs as a comparison sort would, by their first (body, point) and
/// then their second, with two stable counting passes over the points' ranks: the pairs
/// of a shatter are thousands a step, and a comparison sort of them was 1.5 % of
/// toughness 0's run (these passes about 0.5 %).
void sort_pairs(std::vector<PointPair>& pairs, std::span<const std::vector<SweptPoint>> sweeps) {
  std::vector<std::size_t> first_rank(sweeps.size() + 1, 0);  // per body: its point 0's rank
  for (std::size_t b = 0; b < sweeps.size(); ++b) first_rank[b + 1] = first_rank[b] + sweeps[b].size();
  const std::size_t ranks = first_rank.back();
  std::vector<PointPair> by_second;
  stable_counting_sort(pairs, by_second, ranks,
                       [&](const PointPair& p) { return first_rank[std::get<2>(p)] + std::get<3>(p); });
  stable_counting_sort(by_second, pairs, ranks,
                       [&](const PointPair& p) { return first_rank[std::get<0>(p)] + std::get<1>(p); });
}

}  // namespace

std::vector<PointPair> self_collision_pairs(std::span<const std::vector<SweptPoint>> sweeps,
                                            std::span<const std::vector<Index>> piece, std::size_t max_pairs) {
  std::vector<Candidate> candidates = candidates_near_other_pieces(sweeps, piece);
  // 2. Sweep along the axis where the candidates spread most; ties in a fixed order,
  // so the pairs (and the contacts) do not depend on anything but the state.
  AlignedBox extent;
  for (const Candidate& c : candidates) {
    extent.min = extent.min.cwiseMin(c.box.min);
    extent.max = extent.max.cwiseMax(c.box.max);
  }
  int axis = 0;
  if (!candidates.empty()) (extent.max - extent.min).maxCoeff(&axis);
  std::sort(candidates.begin(), candidates.end(), [axis](const Candidate& x, const Candidate& y) {
    return std::tie(x.box.min[axis], x.body, x.point) < std::tie(y.box.min[axis], y.body, y.point);
  });
  std::vector<PointPair> pairs;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const Candidate& ci = candidates[i];
    for (std::size_t j = i + 1; j < candidates.size() && candidates[j].box.min[axis] <= ci.box.max[axis]; ++j) {
      const Candidate& cj = candidates[j];
      if (cj.piece == ci.piece || !ci.box.overlaps(cj.box)) continue;
      if (pairs.size() == max_pairs) throw_too_many_pairs(candidates, max_pairs);
      if (std::pair{ci.body, ci.point} < std::pair{cj.body, cj.point}) {
        pairs.emplace_back(ci.body, ci.point, cj.body, cj.point);
      } else {
        pairs.emplace_back(cj.body, cj.point, ci.body, ci.point);
      }
    }
  }
  sort_pairs(pairs, sweeps);
  return pairs;
}

}  // namespace fissure::sim
