#include "player/sim/contact_response.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "common/tet_mesh.h"
#include "player/sim/world.h"
#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"

namespace fissure::sim {
namespace {

// A 4×4×3 grid of 0.1 m cubes shatters into single tets at toughness 0 as it lands at
// 2 m/s, and its fragments pile on the ground and on each other: several thousand
// coupled contacts. The response once cycled here (issue 16): a solve with a contact
// active overshot, the next left it inactive, and responses ended on the missing half,
// so pieces sank with a contact every step (13 cm, six sphere radii, in 120 steps).
// With the line search, no sphere sinks by more than half the smallest radius.
TEST(ContactResponse, APileOfFragmentsStaysOnTheGround) {
  const TetMesh cage = testing::grid_cage(Vec3(0, 0, 0.02), Vec3(0.4, 0.4, 0.3), 4, 4, 3);
  BodyDescription body =
      testing::describe("grid", cage, Material{.density = 1000, .youngs_modulus = 2e5, .poisson_ratio = 0.3});
  body.toughness = 0.0;
  body.velocity = Matrix3Xd::Zero(3, cage.rest_positions.cols());
  body.velocity.row(2).setConstant(-2.0);
  Environment environment;
  environment.ground = Plane{};  // z = 0, z up, as gravity
  WorldSettings settings;
  settings.fracture = true;
  settings.self_collision = true;
  World world({body}, environment, {}, settings);
  double deepest = 0.0;
  for (int i = 0; i < 120; ++i) {
    ASSERT_TRUE(world.step().status.ok()) << "step " << i;
    deepest = std::max(deepest, world.sphere_penetration());
  }
  const std::vector<double>& radius = world.bodies()[0].spheres.radius;
  const double smallest = *std::min_element(radius.begin(), radius.end());
  std::printf("%u fragments; deepest sphere penetration %.3g m, smallest radius %.3g m\n", world.fragment_count(),
              deepest, smallest);
  EXPECT_GT(world.fragment_count(), cage.tet_count() / 2);  // it did shatter into a pile
  EXPECT_LT(deepest, 0.5 * smallest);
}

}  // namespace
}  // namespace fissure::sim
