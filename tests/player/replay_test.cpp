// Replay: a run recorded with TrajectoryRecorder, read back and played in a fresh world,
// poses that world exactly as the run had it (nodes, cracked topology, fragments,
// projectiles) at every frame, in any order; and a trajectory from elsewhere is refused.
#include "player/app/replay.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "common/error.h"
#include "player/app/run_loop.h"
#include "player/app/trajectory_recorder.h"
#include "tests/support/sim_fixtures.h"
#include "tests/support/temp_dir.h"

namespace fissure::player {
namespace {

/// What a viewer draws of a world: enough to tell any two frames of a breaking run apart.
struct Snapshot {
  double time = 0;
  Matrix3Xd positions;
  Matrix4Xu tets;
  std::vector<sim::FaceState> faces;
  std::vector<Index> fragment;
  Vec3 ball;
  bool ball_launched = false;  ///< launched at 0.02 s: the first frames have it waiting
};

/// Bit for bit (Eigen's == needs equal sizes: checked first).
bool identical(const Snapshot& a, const Snapshot& b) {
  return a.time == b.time && a.positions.cols() == b.positions.cols() && a.positions == b.positions &&
         a.tets.cols() == b.tets.cols() && a.tets == b.tets && a.faces == b.faces && a.fragment == b.fragment &&
         a.ball == b.ball && a.ball_launched == b.ball_launched;
}

Snapshot snapshot(const sim::World& world) {
  const sim::BodyFrame f = world.frame(0, false);
  return {world.time(), f.positions, f.tets, {f.faces.begin(), f.faces.end()}, {f.fragment.begin(), f.fragment.end()},
          world.projectiles()[0].position, world.projectiles()[0].launched};
}

class Snapshots : public RunObserver {
 public:
  void on_start(const sim::World& world) override { all.push_back(snapshot(world)); }
  void on_step(const sim::World& world, const sim::StepReport& /*report*/, long /*step*/) override {
    all.push_back(snapshot(world));
  }
  std::vector<Snapshot> all;  ///< per step, from step 0
};

/// Runs the breaking bar for `steps`, recording every step; returns the run's snapshots.
std::vector<Snapshot> record_breaking_bar(const std::filesystem::path& file, long steps) {
  auto world = testing::breaking_bar().make();
  RunLoop loop(*world);
  TrajectoryRecorder recorder(file, "bar.toml", 1);
  Snapshots snapshots;
  loop.add(recorder);
  loop.add(snapshots);
  loop.run_steps(steps);
  return snapshots.all;
}

TEST(Replay, PosesAFreshWorldExactlyAsTheRecordedRunHadItAtEveryFrameForwardsAndBack) {
  testing::TempDir dir;
  const auto file = dir.path() / "bar.h5";
  const std::vector<Snapshot> run = record_breaking_bar(file, 100);
  ASSERT_GT(run.back().fragment.empty() ? 0 : *std::max_element(run.back().fragment.begin(), run.back().fragment.end()), 0u)
      << "the run must break the bar, or the replay of its topology is not tested";

  auto world = testing::breaking_bar().make();
  Replay replay(formats::read_trajectory(file), file.string(), *world);
  ASSERT_EQ(replay.frame_count(), run.size());
  // Forwards, then every frame in a shuffled order (long jumps both ways), then back to 0.
  std::vector<std::size_t> order(run.size());
  for (std::size_t f = 0; f < order.size(); ++f) order[f] = f;
  std::vector<std::size_t> shuffled = order;
  std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(7));
  order.insert(order.end(), shuffled.begin(), shuffled.end());
  order.push_back(0);
  for (const std::size_t f : order) {
    replay.seek(*world, f);
    ASSERT_EQ(replay.frame(), f);
    ASSERT_TRUE(identical(snapshot(*world), run[f])) << "frame " << f;
  }
  EXPECT_EQ(world->fragment_count(), 1u);
}

TEST(Replay, FrameAtFindsTheLastFrameRecordedAtOrBeforeATime) {
  testing::TempDir dir;
  const auto file = dir.path() / "bar.h5";
  record_breaking_bar(file, 4);
  auto world = testing::breaking_bar().make();
  const Replay replay(formats::read_trajectory(file), file.string(), *world);
  const double dt = world->settings().step.dt;
  EXPECT_EQ(replay.frame_at(-1.0), 0u);
  EXPECT_EQ(replay.frame_at(0.0), 0u);
  EXPECT_EQ(replay.frame_at(2.5 * dt), 2u);
  EXPECT_EQ(replay.frame_at(100.0), 4u);
}

TEST(Replay, RefusesATrajectoryOfAnotherSceneNamingTheFile) {
  testing::TempDir dir;
  const auto file = dir.path() / "bar.h5";
  record_breaking_bar(file, 2);
  testing::SceneParts other = testing::breaking_bar();
  other.bodies[0].name = "beam";
  try {
    Replay(formats::read_trajectory(file), file.string(), *other.make());
    FAIL() << "a trajectory of body 'bar' replayed in a scene of 'beam'";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'beam'"), std::string::npos) << e.what();
  }
  other = testing::breaking_bar();
  other.projectiles.clear();
  EXPECT_THROW(Replay(formats::read_trajectory(file), file.string(), *other.make()), Error);
}

TEST(Replay, RefusesASplitThatDoesNotFitTheCageBeforeChangingIt) {
  testing::TempDir dir;
  const auto file = dir.path() / "bar.h5";
  record_breaking_bar(file, 40);
  formats::Trajectory t = formats::read_trajectory(file);
  ASSERT_FALSE(t.splits.empty());
  auto world = testing::breaking_bar().make();
  const Matrix4Xu before = world->frame(0, false).tets;
  // A split of an original node moving a tet that never held it (splits only ever give a
  // tet newer nodes), and one moving a tet the cage does not have.
  const Matrix4Xu& tets = world->frame(0, false).tets;
  const Index original_nodes = world->bodies()[0].integrator().node_count();
  const auto s = std::find_if(t.splits.begin(), t.splits.end(), [&](const auto& x) { return x.node < original_nodes; });
  ASSERT_NE(s, t.splits.end());
  formats::Trajectory bad_tet = t, no_tet = t;
  for (Eigen::Index other = 0; other < tets.cols(); ++other) {
    if ((tets.col(other).array() != s->node).all()) {
      bad_tet.splits[static_cast<std::size_t>(s - t.splits.begin())].moved[0] = static_cast<TetIndex>(other);
      break;
    }
  }
  no_tet.splits.back().moved.back() = static_cast<TetIndex>(tets.cols() + 5);
  for (const formats::Trajectory& bad : {bad_tet, no_tet}) {
    Replay replay(bad, file.string(), *world);
    EXPECT_THROW(replay.seek(*world, replay.frame_count() - 1), Error);
    EXPECT_TRUE(world->frame(0, false).tets == before);
  }
}

}  // namespace
}  // namespace fissure::player
