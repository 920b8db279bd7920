// The self-collision broad phase (player/sim/contacts/broad_phase.h): bodies piled inside one
// another make every point meet every other; past a limit that is an error, not an
// allocation that grows with the square of the points (issue 46).
#include "player/sim/contacts/broad_phase.h"

#include <gtest/gtest.h>

#include "common/error.h"

namespace fissure::sim {
namespace {

/// `bodies` bodies of `points` points each, all at the origin, each body one piece.
struct Pile {
  std::vector<std::vector<SweptPoint>> sweeps;
  std::vector<std::vector<Index>> piece;
  Pile(int bodies, int points) {
    for (int b = 0; b < bodies; ++b) {
      sweeps.emplace_back(points, SweptPoint{Vec3::Zero(), Vec3::Zero(), 0.1});
      piece.emplace_back(points, 0);
    }
  }
};

TEST(BroadPhase, EveryPairOfAPileIsFoundWithinTheLimit) {
  const Pile pile(4, 5);
  const auto pairs = self_collision_pairs(pile.sweeps, pile.piece, 150);
  EXPECT_EQ(pairs.size(), 6u * 25u);  // C(4, 2) bodies × 5 × 5 points
}

TEST(BroadPhase, APilePastThePairLimitIsAnErrorSayingHowManyBodiesAndSpheres) {
  const Pile pile(4, 5);
  try {
    (void)self_collision_pairs(pile.sweeps, pile.piece, 149);
    FAIL() << "no error past the limit";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("more than 149 pairs of collision spheres overlap at once (20 spheres of up to 4 bodies"),
              std::string::npos)
        << what;
    EXPECT_NE(e.hint().find("place the objects apart"), std::string::npos);
  }
}

// A point of piece kInvalidIndex (a reserve sphere: CollisionBody::obstacles_only)
// meets no other point.
TEST(BroadPhase, APointOfNoPieceMeetsNothing) {
  Pile pile(4, 5);
  pile.piece[1][2] = kInvalidIndex;
  pile.piece[3][0] = kInvalidIndex;
  const auto pairs = self_collision_pairs(pile.sweeps, pile.piece, 150);
  EXPECT_EQ(pairs.size(), 6u * 25u - 2u * 15u + 1u);  // each meets 15 others, and they each other
  for (const auto& [b0, k0, b1, k1] : pairs) {
    EXPECT_NE(pile.piece[b0][k0], kInvalidIndex);
    EXPECT_NE(pile.piece[b1][k1], kInvalidIndex);
  }
}

}  // namespace
}  // namespace fissure::sim
