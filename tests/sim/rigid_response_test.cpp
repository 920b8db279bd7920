// The contact response of a large fragment at rest, answered as a rigid body
// (player/sim/contacts/rigid_response.h): when it applies, what it keeps of the
// deformable answer, and that it never adds energy.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <memory>

#include "player/sim/world.h"
#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"

namespace fissure::sim {
namespace {

/// A 0.2 m block of 5×5×5 nodes (125: a large fragment) dropped from 1 mm onto the
/// ground, with friction, sliding sideways at `speed`.
testing::SceneParts block_on_ground(double resting_speed, double speed = 0.0, double youngs_modulus = 2e5) {
  const TetMesh cage = testing::grid_cage(Vec3(0, 0, 0.001), Vec3(0.2, 0.2, 0.201), 4, 4, 4);
  testing::SceneParts s;
  s.bodies.push_back(testing::describe("block", cage, Material{.density = 1000, .youngs_modulus = youngs_modulus, .poisson_ratio = 0.3}));
  s.bodies[0].contact = {.restitution = 0.0, .friction = 0.5};
  s.bodies[0].velocity = Matrix3Xd::Zero(3, cage.rest_positions.cols());
  s.bodies[0].velocity.row(0).setConstant(speed);
  s.environment.ground = Plane{.normal = Vec3::UnitZ(), .offset = 0, .material = {.restitution = 0.0, .friction = 0.5}};
  s.settings.contacts.rigid_resting_speed = resting_speed;
  return s;
}

struct Rest {
  std::size_t rigid_answers = 0;
  double deepest = 0;        ///< [m] the deepest sphere in the ground after any step
  double highest_gain = 0;   ///< [J] the most the energy ever stood above the start
  Vec3 centre = Vec3::Zero();  ///< of mass, at the end
};

/// Runs `steps` steps; counts the rigid answers from step `count_from` on.
Rest settle(const testing::SceneParts& scene, int steps, int count_from = 0) {
  const auto world = scene.make();
  const double start = world->total_energy();
  Rest rest;
  for (int i = 0; i < steps; ++i) {
    const StepReport report = world->step();
    EXPECT_TRUE(report.status.ok()) << "step " << i;
    if (i >= count_from) rest.rigid_answers += report.contacts.rigid_answers;
    rest.deepest = std::max(rest.deepest, world->sphere_penetration());
    rest.highest_gain = std::max(rest.highest_gain, world->total_energy() - start);
  }
  const ImplicitIntegrator& b = world->bodies()[0].integrator();
  rest.centre = b.positions() * b.node_masses() / b.node_masses().sum();
  return rest;
}

// At rest the block is answered rigidly in every step after its first 1 mm of fall and
// landing, and lies where the deformable answer leaves it, less the sag a rigid answer
// does not make: its centre of mass within ρ g H² / (2E) = 0.98 mm (measured 0.46 mm
// higher), its spheres no deeper than 0.1 mm, and no energy gained.
TEST(RigidResponse, ABlockAtRestIsAnsweredRigidlyAndLiesWhereTheDeformableAnswerLeavesIt) {
  const Rest deformable = settle(block_on_ground(0.0), 240);
  const Rest rigid = settle(block_on_ground(0.2), 240);
  std::printf("block at rest, 240 steps: rigid answers %zu; centre height %.6f m against %.6f m deformable; deepest "
              "sphere %.3g mm against %.3g mm; largest gain %.3g J against %.3g J\n",
              rigid.rigid_answers, rigid.centre.z(), deformable.centre.z(), 1e3 * rigid.deepest, 1e3 * deformable.deepest,
              rigid.highest_gain, deformable.highest_gain);
  EXPECT_EQ(deformable.rigid_answers, 0u);
  EXPECT_GE(rigid.rigid_answers, 200u);
  const double sag = 1000.0 * 9.81 * 0.2 * 0.2 / (2.0 * 2e5);
  EXPECT_GE(rigid.centre.z(), deformable.centre.z());
  EXPECT_LE(rigid.centre.z(), deformable.centre.z() + sag);
  EXPECT_NEAR(rigid.centre.x(), deformable.centre.x(), 5e-4);  // measured 0.13 mm: the sweeps' order creeps
  EXPECT_LE(rigid.deepest, std::max(1.25 * deformable.deepest, 1e-4));
  EXPECT_LE(rigid.highest_gain, 1e-9);
}

// At 1/60 s one step of gravity alone asks 0.16 m/s of each resting contact; the resting
// speed counts beyond it, so a block at rest is still answered rigidly at large steps.
TEST(RigidResponse, ABlockAtRestAtLargeStepsIsStillAnsweredRigidly) {
  for (const double dt : {1.0 / 60.0, 0.1}) {
    testing::SceneParts scene = block_on_ground(0.2);
    scene.settings.step.dt = dt;
    const Rest rest = settle(scene, 60);
    EXPECT_GE(rest.rigid_answers, 50u) << "dt = " << dt;
    EXPECT_LE(rest.highest_gain, 1e-9) << "dt = " << dt;
  }
}

// Sliding at 1 m/s on μ = 0.5 the block stops in v² / (2 μ g) = 0.10 m, answered
// rigidly once its contacts ask less than the resting speed (friction acts on the
// sliding, not the normal velocity): exact Coulomb friction stops it as the lagged
// friction of the deformable answer does, within 1 cm.
TEST(RigidResponse, ASlidingBlockStopsWhereCoulombFrictionStopsIt) {
  const Rest deformable = settle(block_on_ground(0.0, 1.0), 240);
  const Rest rigid = settle(block_on_ground(0.2, 1.0), 240);
  const double travel = 1.0 / (2.0 * 0.5 * 9.81);
  std::printf("block sliding at 1 m/s: travels %.4f m rigid, %.4f m deformable, %.4f m by Coulomb; rigid answers %zu\n",
              rigid.centre.x() - 0.1, deformable.centre.x() - 0.1, travel, rigid.rigid_answers);
  EXPECT_GE(rigid.rigid_answers, 200u);
  EXPECT_NEAR(rigid.centre.x() - 0.1, travel, 0.01);
  EXPECT_NEAR(rigid.centre.x(), deformable.centre.x(), 0.01);
  EXPECT_LE(rigid.highest_gain, 1e-9);
}

// Landing at 2 m/s asks more than the resting speed: the landing is answered with the
// block deformable (it could break there), and only the rest after it rigidly.
TEST(RigidResponse, ALandingIsAnsweredDeformably) {
  testing::SceneParts landing = block_on_ground(0.2);
  landing.bodies[0].velocity.row(2).setConstant(-2.0);
  const auto world = landing.make();
  std::size_t first_contact_step = 0, first_rigid_step = 0;
  for (std::size_t i = 1; i <= 120 && first_rigid_step == 0; ++i) {
    const StepReport report = world->step();
    if (first_contact_step == 0 && report.contacts.contacts > 0) first_contact_step = i;
    if (report.contacts.rigid_answers > 0) first_rigid_step = i;
  }
  EXPECT_GT(first_contact_step, 0u);
  EXPECT_GT(first_rigid_step, first_contact_step);
}

/// Two blocks of E = 2e7, one on the other, from 1 mm over the ground and over each
/// other (the softer blocks of the tests above ring after the top one lands, and their
/// contacts ask 0.3 m/s for dozens of steps).
testing::SceneParts stack(double resting_speed) {
  testing::SceneParts s = block_on_ground(resting_speed, 0.0, 2e7);
  testing::SceneParts top = block_on_ground(resting_speed, 0.0, 2e7);
  top.bodies[0].rest.row(2).array() += 0.201;
  top.bodies[0].name = "top";
  s.bodies.push_back(top.bodies[0]);
  s.settings.self_collision = true;  // bodies touch each other only with it
  return s;
}

/// The top block's centre of mass.
double top_height(const World& world) {
  const ImplicitIntegrator& b = world.bodies()[1].integrator();
  return (b.positions() * b.node_masses() / b.node_masses().sum()).z();
}

/// The all-deformable and the rigid-at-rest world of a scene, stepped side by side.
struct SideBySide {
  std::unique_ptr<World> deformable, rigid;
  std::size_t rigid_answers = 0;  ///< the rigid world's, from step `count_from` on
  double deepest = 0;             ///< [m] the rigid world's deepest sphere in the ground
  double highest_gain = 0;        ///< [J] the most the rigid world's energy stood above its start
};

SideBySide settle_side_by_side(testing::SceneParts (*scene)(double resting_speed), int steps, int count_from) {
  SideBySide out;
  out.deformable = scene(0.0).make();
  out.rigid = scene(0.2).make();
  const double start = out.rigid->total_energy();
  for (int i = 0; i < steps; ++i) {
    EXPECT_TRUE(out.deformable->step().status.ok()) << "step " << i;
    const StepReport report = out.rigid->step();
    EXPECT_TRUE(report.status.ok()) << "step " << i;
    if (i >= count_from) out.rigid_answers += report.contacts.rigid_answers;
    out.deepest = std::max(out.deepest, out.rigid->sphere_penetration());
    out.highest_gain = std::max(out.highest_gain, out.rigid->total_energy() - start);
  }
  return out;
}

// A block resting on another is a rigid body on a rigid body: both are answered in one
// problem of sequential impulses, each a rigid group (sequential_impulses.h). Once the
// top block has landed (30 steps in), both are answered rigidly in nearly every step of
// the 90 after (both in every step would be 180), the stack stands where the
// deformable answer leaves it less the two blocks' sag (at most 3 ρ g H² / (2E): the
// lower block carries the upper's weight too), give or take 0.1 mm either way for how
// the landing, answered deformably in both worlds, left the blocks' spheres overlapping
// (measured 0.259990 m rigid against 0.259949 m deformable; 0.259922 m rigid before
// stalled contacts stiffened, ContactSettings::stalled_penalty_growth), no sphere sinks
// deeper than 0.1 mm and no energy is gained.
TEST(RigidResponse, AStackAtRestIsAnsweredAsTwoRigidBodies) {
  const SideBySide s = settle_side_by_side(stack, 120, 30);
  std::printf("stack at rest, 90 steps: rigid answers %zu; top centre %.6f m against %.6f m deformable; deepest "
              "sphere %.3g mm\n",
              s.rigid_answers, top_height(*s.rigid), top_height(*s.deformable), 1e3 * s.deepest);
  EXPECT_GE(s.rigid_answers, 160u);
  const double sag = 3.0 * 1000.0 * 9.81 * 0.2 * 0.2 / (2.0 * 2e7);
  EXPECT_GE(top_height(*s.rigid), top_height(*s.deformable) - 1e-4);
  EXPECT_LE(top_height(*s.rigid), top_height(*s.deformable) + sag + 1e-4);
  EXPECT_LE(s.deepest, 1e-4);
  EXPECT_LE(s.highest_gain, 1e-9);
}

/// An 8 cm pebble of 64 nodes (a small body: an exact block) 1 mm over the block.
testing::SceneParts pebble_on_block(double resting_speed) {
  testing::SceneParts scene = block_on_ground(resting_speed, 0.0, 2e7);
  const TetMesh pebble = testing::grid_cage(Vec3(0.06, 0.06, 0.202), Vec3(0.14, 0.14, 0.282), 3, 3, 3);
  scene.bodies.push_back(
      testing::describe("pebble", pebble, Material{.density = 1000, .youngs_modulus = 2e7, .poisson_ratio = 0.3}));
  scene.bodies[1].contact = {.restitution = 0.0, .friction = 0.5};
  scene.settings.self_collision = true;
  return scene;
}

/// The pebble's lowest node over the block's highest [m] (below 0: the spheres lie inside
/// the solids, so the two overlap by the spheres' margins).
double pebble_gap(const World& world) {
  return world.bodies()[1].integrator().positions().row(2).minCoeff() -
         world.bodies()[0].integrator().positions().row(2).maxCoeff();
}

// A small body resting on a large one is debris on a resting piece: the small body's
// exact block and the large one's six unknowns are answered in one problem of sequential
// impulses. Before, a large fragment touched by anything but an obstacle was answered
// deformably, with everything joined to it, by the augmented Lagrangian. Once the pebble
// has landed (30 steps in), the block is answered rigidly in nearly every step (90 at
// most), the pebble rests where the deformable answer leaves it (within 0.5 mm), no
// sphere sinks deeper than 0.1 mm into the ground and no energy is gained.
TEST(RigidResponse, DebrisOnAPieceAtRestIsAnsweredWithThePieceRigid) {
  const SideBySide s = settle_side_by_side(pebble_on_block, 120, 30);
  std::printf("pebble on a block, 90 steps: rigid answers %zu; the pebble's gap %.3f mm against %.3f mm deformable; "
              "deepest sphere %.3g mm\n",
              s.rigid_answers, 1e3 * pebble_gap(*s.rigid), 1e3 * pebble_gap(*s.deformable), 1e3 * s.deepest);
  EXPECT_GE(s.rigid_answers, 80u);
  EXPECT_NEAR(pebble_gap(*s.rigid), pebble_gap(*s.deformable), 5e-4);
  EXPECT_LE(s.deepest, 1e-4);
  EXPECT_LE(s.highest_gain, 1e-9);
}

// A ball dropped at 5 m/s on the pebble reaches the block through it in the same answer:
// the island holds a hit, so the block is answered deformably in the steps the ball
// touches the pebble (it could break there), and rigidly again once they have passed.
TEST(RigidResponse, AHitOnDebrisLyingOnAPieceAtRestFindsThePieceDeformable) {
  testing::SceneParts scene = pebble_on_block(0.2);
  scene.projectiles.push_back(Projectile{.position = Vec3(0.1, 0.1, 0.36), .velocity = Vec3(0, 0, -5), .radius = 0.03,
                                         .mass = 0.5, .launch_time = 0.125, .material = {}});
  const auto world = scene.make();
  int hit_steps = 0, rigid_in_hit_steps = 0, rigid_after = 0;
  for (int i = 0; i < 120; ++i) {
    const Vec3 before = world->projectiles()[0].velocity;
    const StepReport report = world->step();
    ASSERT_TRUE(report.status.ok()) << "step " << i;
    const bool hit = world->projectiles()[0].launched && (world->projectiles()[0].velocity - before).norm() > 0.5;
    hit_steps += hit ? 1 : 0;
    rigid_in_hit_steps += hit ? report.contacts.rigid_answers : 0;
    if (hit_steps > 0 && !hit) rigid_after += report.contacts.rigid_answers;
  }
  std::printf("ball on the pebble: %d hit steps, %d rigid answers in them, %d after\n", hit_steps, rigid_in_hit_steps,
              rigid_after);
  EXPECT_GE(hit_steps, 1);
  EXPECT_EQ(rigid_in_hit_steps, 0);
  EXPECT_GE(rigid_after, 20);
}

}  // namespace
}  // namespace fissure::sim
