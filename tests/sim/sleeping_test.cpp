// Fragments asleep (sim/sleeping.h): a body at rest is held still, a hit wakes it in
// the step of the hit (taken again), and sleeping never adds energy.
#include "player/sim/contacts/sleeping.h"

#include <gtest/gtest.h>

#include <cstdio>

#include "tests/support/sim_fixtures.h"

namespace fissure::sim {
namespace {

struct LateBallRun {
  std::size_t most_asleep = 0, asleep_at_end = 0, splits = 0;
  int retaken = 0;
  double highest_over_given = 0;  ///< the largest total energy ÷ (start + put in)
  Vec3 ball_velocity = Vec3::Zero();  ///< at 1.05 s, just after the hit
  Index fragments = 0;
};

/// The breaking bar (sim_fixtures.h) with its ball launched at t = 1 s instead of
/// 0.02 s, so the bar lands (from 5 cm) and comes to rest first; 300 steps of 1/240 s
/// (the ball reaches the bar at about 1.03 s).
LateBallRun run_late_ball(double sleep_speed) {
  testing::SceneParts s = testing::breaking_bar();
  s.projectiles[0].launch_time = 1.0;
  s.settings.sleep = {sleep_speed, 0.25};
  const auto world = s.make();
  const double start = world->total_energy();
  LateBallRun run;
  for (int i = 0; i < 300; ++i) {
    const StepReport report = world->step();
    EXPECT_TRUE(report.status.ok()) << "step " << i;
    run.most_asleep = std::max(run.most_asleep, report.fragments_asleep);
    run.asleep_at_end = report.fragments_asleep;
    run.retaken += report.retaken_to_wake;
    run.splits += report.splits.size();
    run.highest_over_given = std::max(run.highest_over_given, world->total_energy() / (start + world->energy_put_in()));
    if (i == 251) run.ball_velocity = world->projectiles()[0].velocity;
  }
  run.fragments = world->fragment_count();
  return run;
}

TEST(Sleeping, ABarAtRestSleepsAndTheBallThatHitsItFindsItAwake) {
  const LateBallRun awake = run_late_ball(0.0), sleeping = run_late_ball(0.02);
  std::printf("never asleep: the ball at %.3f m/s after the hit, %zu splits, %u fragments, peak %.6f of what was given\n",
              awake.ball_velocity.norm(), awake.splits, awake.fragments, awake.highest_over_given);
  std::printf("asleep first: the ball at %.3f m/s after the hit, %zu splits, %u fragments, peak %.6f; %d steps taken again\n",
              sleeping.ball_velocity.norm(), sleeping.splits, sleeping.fragments, sleeping.highest_over_given,
              sleeping.retaken);
  EXPECT_EQ(awake.most_asleep, 0u);
  EXPECT_EQ(sleeping.most_asleep, 1u);  // the bar, before the ball
  EXPECT_GE(sleeping.retaken, 1);       // the hit found it asleep and took the step again
  EXPECT_EQ(sleeping.asleep_at_end, 0u);
  // The bar answered the hit as a body, as it does awake: it breaks as much, and the ball
  // leaves it at nearly the same speed (later the break-up, which is chaotic, parts them).
  EXPECT_NEAR(static_cast<double>(sleeping.splits), static_cast<double>(awake.splits), 0.1 * awake.splits);
  EXPECT_NEAR(sleeping.ball_velocity.norm(), awake.ball_velocity.norm(), 0.05 * awake.ball_velocity.norm());
  EXPECT_LE(sleeping.highest_over_given, 1.0 + 1e-6);
}

}  // namespace
}  // namespace fissure::sim
