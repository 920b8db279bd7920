#include "player/sim/world.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>

#include "common/error.h"
#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"
#include "tests/support/temp_dir.h"

namespace fissure::sim {
namespace {

#if defined(FISSURE_WITH_CHOLMOD)
constexpr bool kWithCholmod = true;
#else
constexpr bool kWithCholmod = false;  // Eigen's Cholesky rounds differently
#endif

using testing::describe;

/// FNV-1a over the bytes of everything that moves: any difference in any bit changes it.
class Hasher {
 public:
  void add(const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) m_hash = (m_hash ^ p[i]) * 1099511628211ull;
  }
  void add(const Matrix3Xd& m) { add(m.data(), static_cast<std::size_t>(m.size()) * sizeof(double)); }
  void add(const Vec3& v) { add(v.data(), 3 * sizeof(double)); }
  [[nodiscard]] std::uint64_t value() const { return m_hash; }

 private:
  std::uint64_t m_hash = 1469598103934665603ull;
};

std::uint64_t state_hash(const World& world) {
  Hasher h;
  for (const Body& b : world.bodies()) {
    h.add(b.integrator().positions());
    h.add(b.integrator().velocities());
    const Matrix4Xu& tets = b.integrator().elasticity().tets();
    h.add(tets.data(), static_cast<std::size_t>(tets.size()) * sizeof(Index));
    h.add(b.topology.tet_fragment().data(), b.topology.tet_fragment().size() * sizeof(Index));
  }
  for (const Projectile& p : world.projectiles()) {
    h.add(p.position);
    h.add(p.velocity);
  }
  return h.value();
}

// --- Determinism -----------------------------------------------------------------------

struct RunSummary {
  std::uint64_t hash = 0;
  std::size_t splits = 0, contacts = 0, swept = 0;
  Index fragments = 0;
};

/// testing::breaking_bar() for 100 steps on `threads` threads.
RunSummary run_breaking_scene(int threads) {
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  const auto world_ptr = testing::breaking_bar().make();
  World& world = *world_ptr;
  RunSummary out;
  for (int i = 0; i < 100; ++i) {
    const StepReport report = world.step();
    out.splits += report.splits.size();
    out.contacts += report.contacts.contacts;
    out.swept += report.contacts.swept;
  }
  out.hash = state_hash(world);
  out.fragments = world.fragment_count();
  return out;
}

TEST(World, BitIdenticalAcrossThreadCountsAndRuns) {
  const RunSummary one = run_breaking_scene(1);
  std::printf("breaking scene: %zu splits, %u fragments, %zu contacts (%zu swept), hash %016llx\n", one.splits,
              one.fragments, one.contacts, one.swept, static_cast<unsigned long long>(one.hash));
  // The scene exercises what could break determinism: fracture, contacts, self-collision.
  EXPECT_GT(one.splits, 0u);
  EXPECT_GE(one.fragments, 2u);
  EXPECT_GT(one.contacts, 0u);
  EXPECT_EQ(run_breaking_scene(1).hash, one.hash);
  EXPECT_EQ(run_breaking_scene(2).hash, one.hash);
  EXPECT_EQ(run_breaking_scene(4).hash, one.hash);
}

// Pins the breaking scene's state after 100 steps to a constant (Box2D's
// test_determinism.c does the same), so a refactoring that claims to change no
// behaviour can prove it. The value depends on:
//  - the sparse Cholesky: CHOLMOD, or Eigen's (FISSURE_WITH_CHOLMOD=OFF, the portable
//    preset), which round differently;
//  - with CHOLMOD, OpenBLAS's kernel inside its supernodal factorization, which OpenBLAS
//    picks by CPU at run time: CTest holds it to OPENBLAS_CORETYPE=Prescott on x86-64
//    (tests/CMakeLists.txt);
//  - the compiler and its flags (Debian 12's GCC 12, -O3, -ffp-contract=off for the
//    physics), Eigen 3.4 and CHOLMOD 3 (SuiteSparse 5.12).
// It does not depend on the thread count (the test above), nor on whether the CPU has
// AVX2 and FMA: without FMA contraction the x86-64-v3 clones round like the baseline.
// History: taken at 32b2c8e before the player-structure work (issue 13) as
// 8627ce68eb0cfbd6 (Haswell kernels, FMA contraction on) and held across that work's
// refactoring; changed once, when the physics stopped contracting FMAs and the tests
// moved to the Prescott kernels, to be the same on every x86-64 machine; and again
// when fragments started turning on arcs (issue 16, player/sim/rigid_rotation.h); and
// when restitution was kept within each substep's energy and split-born sphere overlaps
// were held (issue 16, EnergyGuard::keep_restitution_within, split_overlaps.h); and when the
// contact response's steps took a line search, and its momentum balance left the
// pieces without contacts alone (issue 16, contact_response.cpp); and when the
// response's iterations also stopped only once no contact pushed past its target, and
// substeps that gain beyond what the run was given were taken again as halves (issue 16);
// and when the response was preconditioned with small fragments' dense blocks and its
// line search became a bracketed Newton search (issue 16, block_jacobi.h); and when the
// response judged its targets with its momentum shift, asked each inner solve to reduce
// its residual and let no contact miss by more than its reach per step (issue 16,
// session 26); and when the debris' contacts were answered by sequential impulses
// (issue 42, contacts/sequential_impulses.h: the bar's small pieces); and when that answer
// was applied without the momentum shift, which was only rounding there
// (JointSystem::apply_exact, issue 42); and when the response's stalled contacts
// stiffened (ContactSettings::stalled_penalty_growth, issue 42).
#if defined(__x86_64__)
TEST(World, BreakingSceneMatchesItsPinnedHash) {
  const std::uint64_t hash = run_breaking_scene(2).hash;
  if (kWithCholmod) {
    const char* coretype = std::getenv("OPENBLAS_CORETYPE");
    ASSERT_TRUE(coretype != nullptr && std::string(coretype) == "Prescott")
        << "the pinned hash is of OpenBLAS's Prescott kernels: run through CTest, which sets OPENBLAS_CORETYPE";
    EXPECT_EQ(hash, 0xc7159dcd0c739daeull);
  } else {
    EXPECT_EQ(hash, 0xf5dfeb288740ff77ull);  // Eigen's Cholesky calls no BLAS
  }
}
#endif

// A step above max_substep is its substeps, each with its own fracture and contacts:
// bit for bit what the same world does when stepped at the substep itself.
TEST(World, AStepAboveMaxSubstepIsItsSubstepsTakenOneByOne) {
  testing::SceneParts coarse = testing::breaking_bar(), fine = testing::breaking_bar();
  fine.settings.step.dt = 1.0 / 240.0;
  fine.settings.max_substep = 0.0;
  coarse.settings.step.dt = 3.0 / 240.0;
  coarse.settings.max_substep = 1.0 / 240.0;
  const auto a = coarse.make(), b = fine.make();
  EXPECT_EQ(a->planned_substeps(), 3);
  EXPECT_EQ(b->planned_substeps(), 1);
  std::size_t splits = 0;
  for (int i = 0; i < 40; ++i) {
    const StepReport report = a->step();
    ASSERT_TRUE(report.status.ok());
    EXPECT_EQ(report.substeps, 3);
    splits += report.splits.size();
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(b->step().status.ok());
  }
  ASSERT_GT(splits, 0u) << "the ball should have broken the bar by now";
  EXPECT_EQ(a->bodies()[0].integrator().positions(), b->bodies()[0].integrator().positions());
  EXPECT_EQ(a->bodies()[0].topology.tet_fragment(), b->bodies()[0].topology.tet_fragment());
  EXPECT_EQ(a->time(), b->time());
  // More than 10,000 substeps per step is refused.
  coarse.settings.max_substep = coarse.settings.step.dt / 20000;
  testing::expect_error_containing([&] { (void)coarse.make(); }, {"max_substep", "10000"});
}

// A world factors each body at load, for the substep its first step will take: the first
// step then factors nothing (issue 42: the first factorization was the first step's hitch).
TEST(World, FactorsAtLoadSoTheFirstStepFactorsNothing) {
  for (const int substeps : {1, 3}) {
    testing::SceneParts parts = testing::breaking_bar();
    parts.settings.step.solver = LinearSolver::ConjugateGradient;
    parts.settings.step.preconditioner = Preconditioner::LaggedCholesky;
    parts.settings.step.dt = substeps / 240.0;
    parts.settings.max_substep = 1.0 / 240.0;
    const auto world = parts.make();
    EXPECT_EQ(world->bodies()[0].integrator().factorizations(), 1);
    const StepReport first = world->step();
    ASSERT_TRUE(first.status.ok());
    EXPECT_EQ(first.substeps, substeps);
    EXPECT_EQ(first.factorizations, 0) << substeps << " substeps";
  }
}

/// The breaking scene's world, and a twin stepped in lockstep; at the first step that
/// splits nodes, the twin's step fails (a NaN gravity makes the solve non-finite) after
/// its fracture has run. The failed step must leave the twin exactly as it was: stepped
/// again with the right settings, it must reach the same state as the world, bit for bit.
TEST(World, AFailedStepLeavesTheWorldExactlyAsItWas) {
  const testing::SceneParts scene = testing::breaking_bar();
  const auto world_ptr = scene.make(), twin_ptr = scene.make();
  World &world = *world_ptr, &twin = *twin_ptr;
  const WorldSettings settings = scene.settings;
  WorldSettings broken = settings;
  broken.step.gravity = Vec3(0, 0, std::numeric_limits<double>::quiet_NaN());
  int failures = 0;
  for (int i = 0; i < 100 && failures < 3; ++i) {
    const StepReport report = world.step();
    ASSERT_TRUE(report.status.ok());
    if (!report.splits.empty()) {
      const std::uint64_t before = state_hash(twin);
      const std::uint64_t version = twin.frame(0).topology_version;
      const double time = twin.time();
      twin.set_settings(broken);
      const StepReport failed = twin.step();
      EXPECT_EQ(failed.status.outcome, StepOutcome::SolveFailed);
      EXPECT_EQ(failed.status.body, 0u);
      EXPECT_EQ(failed.status.solve, SolveStatus::NonFinite);
      EXPECT_FALSE(failed.splits.empty()) << "the failed step must have split nodes to undo";
      EXPECT_EQ(state_hash(twin), before);
      EXPECT_EQ(twin.frame(0).topology_version, version);
      EXPECT_EQ(twin.time(), time);
      twin.set_settings(settings);
      ++failures;
    }
    const StepReport again = twin.step();
    ASSERT_TRUE(again.status.ok());
    ASSERT_EQ(again.splits.size(), report.splits.size()) << "step " << i;
    ASSERT_EQ(state_hash(twin), state_hash(world)) << "step " << i;
    const BodyFrame a = world.frame(0), b = twin.frame(0);
    ASSERT_TRUE(std::equal(a.faces.begin(), a.faces.end(), b.faces.begin(), b.faces.end())) << "step " << i;
    ASSERT_EQ(a.topology_version, b.topology_version);
    ASSERT_EQ(a.previous_positions, b.previous_positions);
  }
  EXPECT_EQ(failures, 3);
}

// A viewer's live material: set before the first step, the world must step exactly as
// one built with that material (stiffness, masses, damping, toughness and the factor all
// follow); a bad value changes nothing.
TEST(World, ANewMaterialActsFromTheNextStepAsIfTheWorldWereBuiltWithIt) {
  testing::SceneParts original = testing::breaking_bar();
  const sim::Material changed{.density = 2500, .youngs_modulus = 7e5, .poisson_ratio = 0.41, .rayleigh_mass = 0.5};
  testing::SceneParts built = original;
  built.bodies[0].material = changed;
  built.bodies[0].toughness = 9.0;
  const auto edited = original.make();
  const auto reference = built.make();
  edited->set_material(0, changed, 9.0);
  for (int step = 0; step < 60; ++step) {
    ASSERT_TRUE(edited->step().status.ok());
    ASSERT_TRUE(reference->step().status.ok());
  }
  EXPECT_EQ(edited->bodies()[0].integrator().positions(), reference->bodies()[0].integrator().positions());
  EXPECT_EQ(edited->fragment_count(), reference->fragment_count());
  EXPECT_GT(reference->bodies()[0].integrator().node_count(), static_cast<Index>(original.bodies[0].rest.cols()))
      << "the comparison should cover splits";

  const Eigen::VectorXd masses = edited->bodies()[0].integrator().node_masses();
  sim::Material invalid = changed;
  invalid.poisson_ratio = 0.5;
  EXPECT_THROW(edited->set_material(0, invalid, 9.0), Error);
  EXPECT_THROW(edited->set_material(0, changed, -1.0), Error);
  EXPECT_EQ(edited->bodies()[0].integrator().node_masses(), masses);
  EXPECT_EQ(edited->bodies()[0].integrator().material().poisson_ratio, changed.poisson_ratio);
}

// The viewer's live solver settings: a world given new settings before its first step
// steps bit for bit like one built with them (dt, the linear solver and its tolerance,
// fracture off); an invalid dt changes nothing.
TEST(World, NewSettingsActFromTheNextStepAsIfTheWorldWereBuiltWithThem) {
  testing::SceneParts original = testing::breaking_bar();
  sim::WorldSettings changed = original.settings;
  changed.step.dt = 0.5 * original.settings.step.dt;
  changed.step.solver = sim::LinearSolver::ConjugateGradient;
  changed.step.tolerance = 1e-7;
  changed.fracture = false;
  testing::SceneParts built = original;
  built.settings = changed;
  const auto edited = original.make();
  const auto reference = built.make();
  sim::WorldSettings invalid = changed;
  invalid.step.dt = -1.0;
  EXPECT_THROW(edited->set_settings(invalid), Error);
  EXPECT_EQ(edited->settings().step.dt, original.settings.step.dt);
  edited->set_settings(changed);
  for (int step = 0; step < 80; ++step) {
    ASSERT_TRUE(edited->step().status.ok());
    ASSERT_TRUE(reference->step().status.ok());
  }
  EXPECT_EQ(edited->time(), reference->time());
  EXPECT_EQ(edited->bodies()[0].integrator().positions(), reference->bodies()[0].integrator().positions());
  EXPECT_EQ(edited->bodies()[0].integrator().node_count(), static_cast<Index>(original.bodies[0].rest.cols()))
      << "fracture is off: the hit must not split the bar";
}

// A viewer's shot enters at the next step and moves like the scene's projectiles.
TEST(World, AnAddedProjectileEntersAtTheNextStep) {
  const auto world = testing::breaking_bar().make();
  const std::size_t before = world->projectiles().size();
  sim::Projectile shot;
  shot.position = Vec3(0.3, 0.15, 3.0);
  shot.velocity = Vec3(0, 0, -5);
  shot.radius = 0.05;
  world->add_projectile(shot);
  ASSERT_EQ(world->projectiles().size(), before + 1);
  EXPECT_FALSE(world->projectiles().back().launched);
  ASSERT_TRUE(world->step().status.ok());
  const sim::Projectile& p = world->projectiles().back();
  EXPECT_TRUE(p.launched);
  const double dt = world->settings().step.dt;
  EXPECT_NEAR(p.position.z(), 3.0 + dt * (-5.0 - 9.81 * dt), 1e-12);
  sim::Projectile bad = shot;
  bad.radius = 0.0;
  EXPECT_THROW(world->add_projectile(bad), Error);
  bad = shot;
  bad.velocity.x() = NAN;
  EXPECT_THROW(world->add_projectile(bad), Error);
}

TEST(World, TheFrameViewFollowsPositionsSplitsAndFragments) {
  testing::SceneParts scene = testing::breaking_bar();
  scene.settings.self_collision = false;
  const auto world_ptr = scene.make();
  World& world = *world_ptr;
  {
    const BodyFrame rest = world.frame(0);
    for (const Mat3& F : rest.deformation) ASSERT_LT((F - Mat3::Identity()).norm(), 1e-12);
    EXPECT_EQ(rest.previous_positions, rest.positions);
  }
  std::uint64_t version = world.frame(0).topology_version;
  std::size_t fractured_faces = 0;
  for (int i = 0; i < 100; ++i) {
    const Matrix3Xd before = world.bodies()[0].integrator().positions();
    const StepReport report = world.step();
    const BodyFrame f = world.frame(0);
    const ImplicitIntegrator& body = world.bodies()[0].integrator();
    ASSERT_EQ(&f.positions, &body.positions());
    ASSERT_EQ(f.previous_positions.cols(), f.positions.cols());
    // Nodes that existed keep their start-of-step positions; split ones their source's.
    ASSERT_EQ(f.previous_positions.leftCols(before.cols()), before);
    for (const auto& [b, split] : report.splits) ASSERT_EQ(f.previous_positions.col(split.added), before.col(split.node));
    // The version moves exactly when the tets do.
    ASSERT_EQ(f.topology_version != version, !report.splits.empty()) << "step " << i;
    version = f.topology_version;
    ASSERT_EQ(f.faces.size(), 4 * static_cast<std::size_t>(f.tets.cols()));
    ASSERT_EQ(f.fragment.size(), static_cast<std::size_t>(f.tets.cols()));
    fractured_faces += report.exposed.size();
    // F maps every tet's rest edges to its current ones.
    for (TetIndex t = 0; t < f.tets.cols(); t += 37) {
      const Vec3 rest_edge = body.rest_positions().col(f.tets(1, t)) - body.rest_positions().col(f.tets(0, t));
      const Vec3 edge = f.positions.col(f.tets(1, t)) - f.positions.col(f.tets(0, t));
      ASSERT_LT((f.deformation[t] * rest_edge - edge).norm(), 1e-9 * (1.0 + edge.norm()));
    }
  }
  const BodyFrame f = world.frame(0);
  EXPECT_GT(fractured_faces, 0u);
  EXPECT_EQ(static_cast<std::size_t>(std::count(f.faces.begin(), f.faces.end(), FaceState::Fractured)), fractured_faces);
  EXPECT_GE(world.fragment_count(), 2u);
}

// --- Stability grid --------------------------------------------------------------------

enum class Scenario { Sliver, InvertedTet, Projectile, Brittle, Unbreakable, Tumbling };

const char* name(Scenario s) {
  switch (s) {
    case Scenario::Sliver: return "Sliver";
    case Scenario::InvertedTet: return "InvertedTet";
    case Scenario::Projectile: return "Projectile300";
    case Scenario::Brittle: return "Toughness0";
    case Scenario::Unbreakable: return "ToughnessInf";
    case Scenario::Tumbling: return "Tumbling";
  }
  return "?";
}

struct StabilityCase {
  double poisson, youngs, dt;
  Scenario scenario;
  // The loads grid's axes; the first grid keeps these defaults.
  double density = 1000;         ///< [kg/m³]
  double gravity = 9.81;         ///< [m/s²], downwards
  double projectile_speed = 300; ///< [m/s], Scenario::Projectile only
  bool self_collision = true;
  unsigned seed = 1;             ///< draws the ±0.5 m/s velocity noise
  double max_substep = 0.0;      ///< [s] WorldSettings::max_substep (0: dt in one step)
};

std::string case_name(const ::testing::TestParamInfo<StabilityCase>& info) {
  const StabilityCase& c = info.param;
  std::string out = std::string(name(c.scenario)) + "_nu" + (c.poisson == 0.0 ? "0" : "0499") + "_E" +
                    (c.youngs < 1e4 ? "1e3" : "1e11") + "_dt" + (c.dt < 1e-3 ? "1em5" : "0p1");
  return out;
}

/// The grid's scene: a small body (a 3×1×1 bar, or a 3×3×1 plate 1 mm thick) tumbling
/// 5 cm above the ground (1 m/s sideways, 3 rad/s, ±0.5 m/s noise), fracture on,
/// toughness 1 N unless the scenario says otherwise; the case sets density, gravity,
/// the projectile's speed and self-collision.
struct StabilityScene {
  TetMesh cage;
  WorldSettings settings;
  std::unique_ptr<World> world;

  explicit StabilityScene(const StabilityCase& c) {
    const Material material{.density = c.density, .youngs_modulus = c.youngs, .poisson_ratio = c.poisson};
    cage = c.scenario == Scenario::Sliver ? testing::grid_cage(Vec3(0, 0, 0.05), Vec3(0.3, 0.3, 0.05 + 1e-3), 3, 3, 1)
                                          : testing::grid_cage(Vec3(0, 0, 0.05), Vec3(0.3, 0.1, 0.15), 3, 1, 1);
    BodyDescription body = describe("body", cage, material);
    body.toughness = c.scenario == Scenario::Brittle       ? 0.0
                     : c.scenario == Scenario::Unbreakable ? std::numeric_limits<double>::infinity()
                                                           : 1.0;
    body.velocity = Matrix3Xd::Zero(3, cage.rest_positions.cols());
    std::mt19937 rng(c.seed);
    std::uniform_real_distribution<double> u(-0.5, 0.5);
    const Vec3 centre = cage.rest_positions.rowwise().mean();
    for (Index n = 0; n < cage.node_count(); ++n) {
      body.velocity.col(n) = Vec3(1, 0, 0) + Vec3(0, 3, 0).cross(cage.rest_positions.col(n) - centre) +
                             Vec3(u(rng), u(rng), u(rng));
    }
    Environment env;
    env.ground = Plane{};
    std::vector<Projectile> projectiles;
    if (c.scenario == Scenario::Projectile) {
      projectiles.push_back(Projectile{.position = Vec3(-1.0, 0.05, 0.1), .velocity = Vec3(c.projectile_speed, 0, 0),
                                       .radius = 0.05, .mass = 0.1, .launch_time = 0, .material = {},
                                       .launched = false});
    }
    settings.step.dt = c.dt;
    settings.max_substep = c.max_substep;
    settings.step.gravity = Vec3(0, 0, -c.gravity);
    settings.fracture = true;
    settings.self_collision = c.self_collision;
    if (c.scenario == Scenario::InvertedTet) {
      // Mirror tet 0's first node through the plane of its opposite face.
      Matrix3Xd& x = body.positions = cage.rest_positions;
      const Matrix4Xu& tets = cage.tets;
      const Vec3 a = x.col(tets(1, 0)), b = x.col(tets(2, 0)), d = x.col(tets(3, 0));
      const Vec3 n = (b - a).cross(d - a).normalized();
      x.col(tets(0, 0)) -= 2.0 * n.dot(x.col(tets(0, 0)) - a) * n;
    }
    world = std::make_unique<World>(std::vector<BodyDescription>{body}, env, projectiles, settings);
  }

  /// Mechanical energy [J], projectiles included before launch (World counts them from
  /// launch on); potential measured from z = 0, where the ground is.
  [[nodiscard]] double energy() const {
    const Vec3 g = settings.step.gravity;
    double e = 0.0;
    for (const Body& b : world->bodies()) {
      e += b.integrator().kinetic_energy() + b.integrator().elasticity().energy(b.integrator().positions()) -
           g.dot(b.integrator().positions() * b.integrator().node_masses());
    }
    for (const Projectile& p : world->projectiles()) {
      e += 0.5 * p.mass * p.velocity.squaredNorm() - p.mass * g.dot(p.position);
    }
    return e;
  }
};

class Stability : public ::testing::TestWithParam<StabilityCase> {};

/// The deepest any collision sphere may end a step inside the ground or a projectile
/// [m]: the bar's thickness. The contact response once let the heavy bar under 1e4 m/s²
/// sink 16 m and the light one 93 m at dt = 0.1 (its momentum shift undid the contacts
/// after the iterations stopped, its inner solves did nothing once warm, and a share of
/// a speed allowed |g| h² / 10 of sinking; docs/decisions/0021-response-stopping-rule.md); 22 of the
/// grids' cases sank more than this. Now the deepest is 7.3 cm (the light bar hit at
/// 1000 m/s under 1e4 m/s²).
constexpr double kDeepestSinking = 0.1;

/// What a run of the grid's scene did: its peak energy in each half and what the start
/// and the fall made available.
struct EnergyRun {
  double available = 0, first_half = 0, second_half = 0;
  int halvings = 0;                          ///< substeps taken again as halves, summed
  double deepest = 0;                        ///< [m] the largest sphere penetration after a step
  double step_ms_mean = 0, step_ms_max = 0;  ///< wall clock, reported only
  [[nodiscard]] double highest() const { return std::max(first_half, second_half); }
};

/// Runs `steps` steps, asserting at each a finite state, no exception, a step that
/// succeeded and bounded work (splits per step, fragments, substeps); returns the
/// energy it saw.
EnergyRun run_and_check(StabilityScene& scene, int steps) {
  World& world = *scene.world;
  const double initial = scene.energy();
  EnergyRun run{.available = 0, .first_half = initial, .second_half = 0};
  double lowest_potential = 0.0;
  for (int i = 0; i < steps; ++i) {
    StepReport report;
    EXPECT_NO_THROW(report = world.step()) << "step " << i;
    EXPECT_TRUE(report.status.ok()) << "step " << i << ": " << to_string(report.status.outcome);
    const ImplicitIntegrator& s = world.bodies()[0].integrator();
    EXPECT_TRUE(s.positions().allFinite() && s.velocities().allFinite()) << "step " << i;
    for (const Projectile& p : world.projectiles()) EXPECT_TRUE(p.position.allFinite() && p.velocity.allFinite());
    EXPECT_LE(report.splits.size(),
              static_cast<std::size_t>(scene.settings.max_splits_per_step * world.planned_substeps()));  // per substep
    EXPECT_LE(world.fragment_count(), scene.cage.tet_count());
    EXPECT_LE(report.substeps, world.planned_substeps() << scene.settings.energy_halvings) << "step " << i;
    run.halvings += report.energy_halvings;
    run.step_ms_mean += 1e3 * report.total / steps;
    run.step_ms_max = std::max(run.step_ms_max, 1e3 * report.total);
    const double e = scene.energy();
    EXPECT_TRUE(std::isfinite(e)) << "step " << i;
    if (::testing::Test::HasFailure()) break;
    double& half = i < steps / 2 ? run.first_half : run.second_half;
    half = std::max(half, e);
    lowest_potential = std::min(lowest_potential, world.potential_energy());
    run.deepest = std::max(run.deepest, world.sphere_penetration());
  }
  run.available = initial - std::min(0.0, lowest_potential);
  return run;
}

TEST_P(Stability, NoNonFiniteValuesNoExceptionsAndBoundedEnergy) {
  const StabilityCase& c = GetParam();
  StabilityScene scene(c);
  const EnergyRun run = run_and_check(scene, 60);  // 0.6 ms at dt = 1e-5, 6 s at dt = 0.1
  if (HasFailure()) return;
  std::printf("%-36s peak %9.3g J of %9.3g J available (×%.3g), %ld fragments, %d halvings, %.2g ms/step (max "
              "%.2g), sinks %.3g m\n",
              case_name({c, 0}).c_str(), run.highest(), run.available, run.highest() / run.available,
              static_cast<long>(scene.world->fragment_count()), run.halvings, run.step_ms_mean, run.step_ms_max, run.deepest);
  // Never more than there was, +1 % and 1 mJ. The cases at dt = 0.1 with a body that
  // shatters kept it only once a substep that still gained was taken again as halves
  // (WorldSettings::energy_halvings; before: up to ×3.5e8, docs/decisions/0033-halving-substeps-that-gain.md).
  EXPECT_LE(run.highest(), 1.01 * run.available + 1e-3);
  EXPECT_LE(run.deepest, kDeepestSinking);
}

// The runaway the grid's dt = 0.1 rows once had to allow: a 1 mm plate, E = 1e11,
// tumbling onto the ground at dt = 0.1, toughness 1 N. When contact impulses acted after
// the implicit solve, on one tet's nodes at a time, each was an enormous strain in a
// sliver: from 0.1 J the energy was 1.7e9 J after one step and 9e13 J after 60. Inside
// the implicit step (contact_response.h) the plate answers as a whole.
//
// The peak is chaotic: rounding-level changes (the batched element loop's FMA at rest,
// a different noise seed) move it between 17 J and 3.2e4 J, with the same code before
// and after that change (measured over seeds 1-8: before 21 J-2.9e4 J, after 17 J-3.2e4
// J). Those peaks were the tumbling plate stretched by its own spin: each step moved
// its nodes on lines, (hω)²/2 of strain in steel. Since fragments turn on arcs
// (rigid_rotation.h, issue 16) the peak is the start's energy in every seed (measured
// 0.099-0.113 J, nothing gained); so over several seeds the bound is now the real one.
//
// Nearly incompressible (ν = 0.499) it keeps the bound too, and it is the case that
// showed an exact re-solve (EnergyGuard::solve_exactly_if_gaining) must be taken only where
// the linear solve itself gains: re-solving every substep that ended above its budget
// because of its contacts took it to ×1e8 in every seed (docs/decisions/0032-exact-resolve-where-a-substep-gains.md).
TEST(Stability, AStiffSliverOnTheGroundAtLargeStepsDoesNotRunAway) {
  for (const double poisson : {0.0, 0.499}) {
  for (unsigned seed = 1; seed <= 6; ++seed) {
    StabilityScene scene({.poisson = poisson, .youngs = 1e11, .dt = 0.1, .scenario = Scenario::Sliver, .seed = seed});
    const double initial = scene.energy();
    double first_half = initial, second_half = 0.0, last = initial;
    for (int i = 0; i < 120; ++i) {
      scene.world->step();
      last = scene.energy();
      ASSERT_TRUE(std::isfinite(last)) << "seed " << seed << ", step " << i;
      (i < 60 ? first_half : second_half) = std::max(i < 60 ? first_half : second_half, last);
    }
    std::printf("stiff sliver (ν = %g) at dt = 0.1, seed %u: %.3g J → peak %.3g J in the first 6 s, %.3g J in the "
                "next 6 s, %.3g J at the end\n",
                poisson, seed, initial, first_half, second_half, last);
    EXPECT_LE(std::max(first_half, second_half), 1.01 * initial + 1e-3) << "ν = " << poisson << ", seed " << seed;
  }
  }
}

std::vector<StabilityCase> stability_cases() {
  std::vector<StabilityCase> out;
  for (const Scenario s : {Scenario::Sliver, Scenario::InvertedTet, Scenario::Projectile, Scenario::Brittle,
                           Scenario::Unbreakable}) {
    for (const double nu : {0.0, 0.499}) {
      for (const double e : {1e3, 1e11}) {
        for (const double dt : {1e-5, 0.1}) out.push_back({nu, e, dt, s});
      }
    }
  }
  return out;
}

INSTANTIATE_TEST_SUITE_P(Grid, Stability, ::testing::ValuesIn(stability_cases()), case_name);

// The loads grid: the other axes (density, gravity, projectile speed,
// self-collision, noise seeds) on a moderate material at the default step and the
// largest the grid uses, each case asserting the energy bound.
class StabilityUnderLoads : public ::testing::TestWithParam<StabilityCase> {};

std::string load_case_name(const ::testing::TestParamInfo<StabilityCase>& info) {
  const StabilityCase& c = info.param;
  std::string out = c.scenario == Scenario::Projectile ? "Projectile1000" : "Tumbling";
  out += c.density < 1.0 ? "_rho1em3" : "_rho1e6";
  out += c.gravity > 100.0 ? "_g1e4" : "_g9p81";
  out += c.self_collision ? "_self" : "_noself";
  out += c.dt > 1e-2 ? "_dt0p1" : "_dt1by240";
  return out + "_seed" + std::to_string(c.seed);
}

TEST_P(StabilityUnderLoads, NoNonFiniteValuesNoExceptionsAndBoundedEnergy) {
  const StabilityCase& c = GetParam();
  StabilityScene scene(c);
  const EnergyRun run = run_and_check(scene, 60);
  if (HasFailure()) return;
  std::printf("%-48s peak %9.3g J of %9.3g J available (×%.3g), %ld fragments, %d halvings, %.2g ms/step (max "
              "%.2g), sinks %.3g m\n",
              load_case_name({c, 0}).c_str(), run.highest(), run.available, run.highest() / run.available,
              static_cast<long>(scene.world->fragment_count()), run.halvings, run.step_ms_mean, run.step_ms_max, run.deepest);
  // Never more than there was, +1 % and 1 mJ (the 1000 m/s hits at dt = 0.1 under 1e4
  // m/s², or on the light bar, since substeps that gain are taken again as halves).
  EXPECT_LE(run.highest(), 1.01 * run.available + 1e-3);
  EXPECT_LE(run.deepest, kDeepestSinking);
}

std::vector<StabilityCase> load_cases() {
  std::vector<StabilityCase> out;
  for (const Scenario s : {Scenario::Tumbling, Scenario::Projectile}) {
    for (const double density : {1e-3, 1e6}) {
      for (const double gravity : {9.81, 1e4}) {
        for (const bool self_collision : {false, true}) {
          for (const double dt : {1.0 / 240.0, 0.1}) {
            for (unsigned seed = 1; seed <= 2; ++seed) {
              out.push_back({.poisson = 0.3, .youngs = 1e7, .dt = dt, .scenario = s, .density = density,
                             .gravity = gravity, .projectile_speed = 1000, .self_collision = self_collision,
                             .seed = seed});
            }
          }
        }
      }
    }
  }
  return out;
}

INSTANTIATE_TEST_SUITE_P(Grid, StabilityUnderLoads, ::testing::ValuesIn(load_cases()), load_case_name);

// The ends of the ranges the first grid stops short of: the largest step a scene
// accepts (dt = 1 s, which a scene takes in substeps of its default max_substep, 1/60
// s), ν = 0.4999 and E = 1e12 Pa, against the soft compressible corner; each case
// asserting the energy bound. 10 steps: 600 substeps, 10 s of tumbling and landing.
// The 1 mm sliver is left out of the stiff corner for its cost alone: it keeps the
// bound there too, but halves 2,317 substeps in 10 steps, 3.4 s a step (session 23).
class StabilityAtTheLargestStep : public ::testing::TestWithParam<StabilityCase> {};

std::string largest_step_case_name(const ::testing::TestParamInfo<StabilityCase>& info) {
  const StabilityCase& c = info.param;
  return std::string(name(c.scenario)) + (c.youngs > 1e4 ? "_nu04999_E1e12" : "_nu0_E1e3");
}

TEST_P(StabilityAtTheLargestStep, NoNonFiniteValuesNoExceptionsAndBoundedEnergy) {
  const StabilityCase& c = GetParam();
  StabilityScene scene(c);
  const EnergyRun run = run_and_check(scene, 10);
  if (HasFailure()) return;
  std::printf("dt = 1 s, %-30s peak %9.3g J of %9.3g J available (×%.3g), %ld fragments, %d halvings, %.2g ms/step, sinks %.3g m\n",
              largest_step_case_name({c, 0}).c_str(), run.highest(), run.available, run.highest() / run.available,
              static_cast<long>(scene.world->fragment_count()), run.halvings, run.step_ms_mean, run.deepest);
  EXPECT_LE(run.highest(), 1.01 * run.available + 1e-3);  // never more than there was, +1 % and 1 mJ
  EXPECT_LE(run.deepest, kDeepestSinking);
}

std::vector<StabilityCase> largest_step_cases() {
  std::vector<StabilityCase> out;
  for (const Scenario s : {Scenario::Sliver, Scenario::Projectile, Scenario::Brittle, Scenario::Tumbling}) {
    for (const auto& [nu, e] : {std::pair{0.4999, 1e12}, std::pair{0.0, 1e3}}) {
      if (s == Scenario::Sliver && e > 1e4) continue;
      out.push_back({.poisson = nu, .youngs = e, .dt = 1.0, .scenario = s, .max_substep = 1.0 / 60.0});
    }
  }
  return out;
}

INSTANTIATE_TEST_SUITE_P(Grid, StabilityAtTheLargestStep, ::testing::ValuesIn(largest_step_cases()),
                         largest_step_case_name);

// --- Input validation ------------------------------------------------------------------

template <typename F>
void expect_error(F&& make, const std::string& needle) {
  try {
    make();
    ADD_FAILURE() << "no fissure::Error; expected one mentioning '" << needle << "'";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    EXPECT_FALSE(e.hint().empty()) << e.what();
  }
}

TEST(World, OutOfRangeInputsAreErrorsThatSayWhy) {
  const TetMesh cage = testing::grid_cage(Vec3::Zero(), Vec3::Ones(), 1, 1, 1);
  const BodyDescription good = describe("cube", cage, Material{});
  auto world_with = [&](const BodyDescription& body, const WorldSettings& settings) {
    return [=] { World world({body}, {}, {}, settings); };
  };
  EXPECT_NO_THROW(world_with(good, {})());

  BodyDescription negative = good;
  negative.toughness = -1.0;
  expect_error(world_with(negative, {}), "toughness");
  expect_error(world_with(negative, {}), "'cube'");
  BodyDescription nan = good;
  nan.toughness = std::numeric_limits<double>::quiet_NaN();
  expect_error(world_with(nan, {}), "toughness");

  BodyDescription incompressible = good;
  incompressible.material.poisson_ratio = 0.5;
  expect_error(world_with(incompressible, {}), "poisson_ratio");
  BodyDescription soft = good;
  soft.material.youngs_modulus = 0.0;
  expect_error(world_with(soft, {}), "youngs_modulus");

  for (const double dt : {0.0, -0.01, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    WorldSettings settings;
    settings.step.dt = dt;
    expect_error(world_with(good, settings), "time step");
  }

  BodyDescription no_vertices = good;
  WorldSettings exact;
  exact.collision_points = CollisionPoints::RenderVertices;
  expect_error(world_with(no_vertices, exact), "render vertices");

  BodyDescription bad_sphere = good;
  bad_sphere.spheres.tet = {99};
  bad_sphere.spheres.barycentric = {Vec4::Constant(0.25)};
  bad_sphere.spheres.radius = {0.1};
  expect_error(world_with(bad_sphere, {}), "spheres");

  BodyDescription bad_pin = good;
  bad_pin.pinned = {1000};
  expect_error(world_with(bad_pin, {}), "pinned node");
}

}  // namespace
}  // namespace fissure::sim
