// The energy check that ends a run (issue 16): the physics may only lose energy, so a run
// whose total exceeds its start plus the work put in (projectiles launched, velocities
// set from outside) by more than 1% stops, naming the step, the body and a likely cause;
// work put in from outside is not a fault.
#include "player/app/diagnostics.h"

#include <gtest/gtest.h>

#include "player/app/run_loop.h"
#include "tests/support/sim_fixtures.h"

namespace fissure::player {
namespace {

/// The breaking bar without its ball, or with it; fracture off unless asked.
testing::SceneParts bar(bool ball) {
  testing::SceneParts s = testing::breaking_bar();
  if (!ball) s.projectiles.clear();
  s.settings.fracture = false;
  return s;
}

TEST(Diagnostics, EnergyFromNowhereStopsTheRunNamingStepBodyAndCause) {
  auto world = bar(false).make();
  RunLoop loop(*world);
  Diagnostics diagnostics;
  loop.add(diagnostics);
  loop.start();
  ASSERT_EQ(loop.take_steps(5), 5);
  // Stretched by 10% behind the physics' back: elastic energy nobody put in.
  Matrix3Xd stretched = world->frame(0, false).positions;
  stretched.row(0) *= 1.1;
  world->pose(0, stretched);
  loop.take_steps(5);
  ASSERT_TRUE(loop.stopped());
  const RunEnd end = loop.finish();
  ASSERT_TRUE(end.stop.has_value());
  EXPECT_EQ(end.steps, 6);
  const std::string& message = end.stop->message;
  EXPECT_NE(message.find("at step 6 "), std::string::npos) << message;
  EXPECT_NE(message.find("body 'bar'"), std::string::npos) << message;
  EXPECT_NE(message.find("likely cause: the implicit solve straining the body"), std::string::npos) << message;
  EXPECT_NE(end.stop->hint.find("solver.dt"), std::string::npos) << end.stop->hint;
}

// The scene reader bounds speeds, so a non-finite energy is the last net, for states no
// scene can ask for: at 1e200 m/s, ½mv² overflows while every position stays finite.
TEST(Diagnostics, ANonFiniteEnergyStopsTheRunAndSaysWhen) {
  auto world = bar(false).make();
  Diagnostics diagnostics;
  diagnostics.on_start(*world);
  Matrix3Xd v = world->bodies()[0].integrator().velocities();
  v.row(0).array() += 1e200;
  world->set_velocities(0, v);
  diagnostics.on_step(*world, sim::StepReport{}, 7);
  ASSERT_NE(diagnostics.stop_request(), nullptr);
  EXPECT_NE(diagnostics.stop_request()->message.find("at step 7 "), std::string::npos) << diagnostics.stop_request()->message;
  EXPECT_NE(diagnostics.stop_request()->message.find("non-finite"), std::string::npos) << diagnostics.stop_request()->message;
  EXPECT_NE(diagnostics.stop_request()->hint.find("solver.dt"), std::string::npos) << diagnostics.stop_request()->hint;
}

TEST(Diagnostics, WorkPutInFromOutsideIsNotAFault) {
  auto world = bar(true).make();
  RunLoop loop(*world);
  Diagnostics diagnostics;
  loop.add(diagnostics);
  loop.start();
  ASSERT_EQ(loop.take_steps(3), 3);
  // A kick: 2 m/s upwards to every node, more kinetic energy than the bar has in gravity.
  Matrix3Xd v = world->bodies()[0].integrator().velocities();
  v.row(2).array() += 2.0;
  world->set_velocities(0, v);
  loop.take_steps(60);
  EXPECT_FALSE(loop.stopped()) << (loop.end().stop ? loop.end().stop->message : "");
  const RunEnd end = loop.finish();
  const double ball = 0.5 * 3.0 * 40.0 * 40.0;
  EXPECT_GT(diagnostics.energy_put_in, ball) << "the ball's launch and the kick are work put in";
  EXPECT_GT(diagnostics.energy_max, diagnostics.energy_initial + ball) << "the check must have had something to allow";
  EXPECT_LE(diagnostics.energy_max, (diagnostics.energy_initial + diagnostics.energy_put_in) * 1.01);
}

TEST(Diagnostics, TheSlackIsSmallAgainstTheEnergyInTheScene) {
  auto world = bar(false).make();
  Diagnostics diagnostics;
  diagnostics.on_start(*world);
  // 0.1% of lifting the bar by its own size: millijoules for a 54 kg bar of 0.73 m.
  const double mass = world->bodies()[0].integrator().node_masses().sum();
  EXPECT_NEAR(diagnostics.energy_slack, 1e-3 * mass * 9.81 * Vec3(0.6, 0.3, 0.3).norm(), 1e-6);
}

}  // namespace
}  // namespace fissure::player
