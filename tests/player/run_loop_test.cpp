// The run loop: the fixed-step accumulator and how observers see a run.
#include "player/app/run_loop.h"
#include "player/app/run_statistics.h"

#include <gtest/gtest.h>

#include <memory>

#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"

namespace fissure::player {
namespace {

std::unique_ptr<sim::World> falling_cube(double dt) {
  const TetMesh cage = testing::grid_cage(Vec3(0, 0, 1), Vec3(0.2, 0.2, 1.2), 1, 1, 1);
  sim::WorldSettings settings;
  settings.step.dt = dt;
  sim::Environment env;
  env.ground = sim::Plane{};
  return std::make_unique<sim::World>(
      std::vector<sim::BodyDescription>{testing::describe("cube", cage, sim::Material{})}, env,
      std::vector<sim::Projectile>{}, settings);
}

/// Counts what it is told, and asks to stop after `stop_after` steps.
class Counter : public RunObserver {
 public:
  explicit Counter(long stop_after = -1) : m_stop_after(stop_after) {}
  void on_start(const sim::World& /*world*/) override { ++starts; }
  void on_step(const sim::World& /*world*/, const sim::StepReport& /*report*/, long step) override {
    EXPECT_EQ(step, steps + 1);
    steps = step;
    if (step == m_stop_after) m_stop = RunStop{"enough", "none"};
  }
  void on_finish(const sim::World& /*world*/, const RunEnd& end) override {
    ++finishes;
    last_end = end;
  }
  [[nodiscard]] const RunStop* stop_request() const override { return m_stop ? &*m_stop : nullptr; }

  int starts = 0, finishes = 0;
  long steps = 0;
  RunEnd last_end;

 private:
  long m_stop_after;
  std::optional<RunStop> m_stop;
};

TEST(RunLoop, FramesTakeAsManyWholeStepsAsTheirTimeHolds) {
  constexpr double dt = 1.0 / 240.0;
  auto world = falling_cube(dt);
  RunLoop loop(*world);
  Counter counter;
  loop.add(counter);
  loop.start();
  // 30 frames per second: 8 steps each. Frames of 1/100 s: 2.4 steps each, so the
  // accumulator carries the remainder and 100 frames hold exactly 240 steps.
  for (int f = 0; f < 30; ++f) {
    const FrameAdvance frame = loop.advance(1.0 / 30.0);
    // 8 steps, or 7 with a remainder just below dt (1/30 is not exact in binary).
    ASSERT_GE(frame.steps, 7);
    ASSERT_LE(frame.steps, 9);
    ASSERT_GE(frame.alpha, 0.0);
    ASSERT_LT(frame.alpha, 1.0);
  }
  EXPECT_NEAR(static_cast<double>(counter.steps), 240.0, 1.0);
  long before = counter.steps;
  for (int f = 0; f < 100; ++f) loop.advance(0.01);
  EXPECT_NEAR(static_cast<double>(counter.steps - before), 240.0, 1.0);
  EXPECT_NEAR(world->time(), static_cast<double>(counter.steps) * dt, 1e-9);
  const RunEnd end = loop.finish();
  EXPECT_TRUE(end.ok());
  EXPECT_EQ(end.steps, counter.steps);
  EXPECT_EQ(counter.starts, 1);
  EXPECT_EQ(counter.finishes, 1);
}

TEST(RunLoop, ASlowFrameIsCappedAndTheRestOfItsTimeDropped) {
  auto world = falling_cube(0.01);
  RunLoop loop(*world);
  loop.start();
  const FrameAdvance slow = loop.advance(1.0, 16);  // a one-second hitch
  EXPECT_EQ(slow.steps, 16);
  EXPECT_TRUE(slow.dropped);
  EXPECT_EQ(slow.alpha, 0.0);
  const FrameAdvance next = loop.advance(0.025, 16);  // the next frame is normal again
  EXPECT_EQ(next.steps, 2);
  EXPECT_FALSE(next.dropped);
  EXPECT_NEAR(next.alpha, 0.5, 1e-9);
}

TEST(RunLoop, RunStepsMatchesSteppingTheWorldDirectly) {
  auto looped = falling_cube(1.0 / 240.0), direct = falling_cube(1.0 / 240.0);
  RunLoop loop(*looped);
  EXPECT_EQ(loop.run_steps(100).steps, 100);
  for (int i = 0; i < 100; ++i) direct->step();
  EXPECT_EQ(looped->bodies()[0].integrator().positions(), direct->bodies()[0].integrator().positions());
  EXPECT_EQ(looped->time(), direct->time());
}

TEST(RunLoop, AnObserverCanStopTheRunAndEveryoneHearsWhy) {
  auto world = falling_cube(1.0 / 240.0);
  RunLoop loop(*world);
  Counter stopper(5), watcher;
  loop.add(stopper);
  loop.add(watcher);
  const RunEnd end = loop.run_steps(100);
  EXPECT_EQ(end.steps, 5);
  EXPECT_FALSE(end.ok());
  ASSERT_TRUE(end.stop.has_value());
  EXPECT_EQ(end.stop->message, "enough");
  EXPECT_EQ(watcher.steps, 5);  // it saw the step that made the other stop
  EXPECT_EQ(watcher.last_end.steps, 5);
  EXPECT_TRUE(loop.advance(1.0).failed);  // a stopped loop takes no more steps
  EXPECT_EQ(world->time(), 5.0 / 240.0);
}

// The report's p99 is a nearest-rank quantile of every step's time, to within 1.1 % (a
// log histogram with fixed memory): 1..100 ms gives 99 ms, the extremes the minimum and
// the maximum, and a run of no step 0.
TEST(RunStatistics, PhaseQuantilesAreNearestRankToWithinOnePercent) {
  PhaseStats p;
  EXPECT_EQ(p.quantile(0.99), 0.0);
  for (int i = 100; i >= 1; --i) p.add(1e-3 * i);
  EXPECT_NEAR(p.quantile(0.99), 0.099, 0.011 * 0.099);
  EXPECT_NEAR(p.quantile(0.5), 0.050, 0.011 * 0.050);
  EXPECT_NEAR(p.quantile(0.0), 0.001, 0.011 * 0.001);
  EXPECT_LE(p.quantile(1.0), 0.100);
  EXPECT_NEAR(p.quantile(1.0), 0.100, 0.011 * 0.100);
  EXPECT_DOUBLE_EQ(p.max, 0.100);
  // The buckets do not grow with the run.
  const std::size_t buckets = p.buckets.size();
  for (int i = 0; i < 10000; ++i) p.add(1e-4);
  EXPECT_EQ(p.buckets.size(), buckets);
}

// The report keeps the five slowest steps, slowest first, with what each did: the steps
// of 1..20 ms fed in a shuffled order leave steps of 20, 19, 18, 17 and 16 ms, and a
// step no slower than the fifth does not displace it.
TEST(RunStatistics, KeepsTheFiveSlowestStepsSlowestFirst) {
  RunStatistics s;
  const auto world = falling_cube(1.0 / 240.0);
  for (int i = 0; i < 20; ++i) {
    sim::StepReport r;
    const int ms = 1 + (i * 7) % 20;  // 1, 8, 15, 2, … : each of 1..20 once
    r.total = 1e-3 * ms;
    r.factorizations = ms;
    s.on_step(*world, r, i);
  }
  ASSERT_EQ(s.slowest.size(), RunStatistics::kSlowestKept);
  for (std::size_t k = 0; k < s.slowest.size(); ++k) {
    EXPECT_DOUBLE_EQ(s.slowest[k].total, 1e-3 * (20 - static_cast<int>(k)));
    EXPECT_EQ(s.slowest[k].factorizations, 20 - static_cast<int>(k));
    EXPECT_EQ((s.slowest[k].step * 7) % 20 + 1, 20 - static_cast<long>(k));  // its own index
  }
  sim::StepReport tie;
  tie.total = 16e-3;
  s.on_step(*world, tie, 99);
  EXPECT_NE(s.slowest.back().step, 99);
}

}  // namespace
}  // namespace fissure::player
