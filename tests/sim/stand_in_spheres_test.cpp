#include "player/sim/contacts/stand_in_spheres.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "player/sim/world.h"
#include "tests/support/procedural.h"
#include "tests/support/sim_fixtures.h"

namespace fissure::sim {
namespace {

/// One tet, not regular, so its faces' heights differ.
struct OneTet {
  Matrix3Xd rest{3, 4};
  Matrix4Xu tets{4, 1};
  OneTet() {
    rest << 0, 0.3, 0.05, 0.1,  //
        0, 0.02, 0.2, 0.05,     //
        0, 0, 0.01, 0.15;
    tets << 0, 1, 2, 3;
  }
  /// Signed distance from p to the plane of the face opposite corner i, positive inside.
  [[nodiscard]] double inside_distance(const Vec3& p, int i) const {
    const auto& face = kTetFaceNodes[i];
    const Vec3 a = rest.col(face[0]), b = rest.col(face[1]), c = rest.col(face[2]);
    Vec3 n = (b - a).cross(c - a).normalized();
    if (n.dot(rest.col(i) - a) < 0.0) n = -n;
    return n.dot(p - a);
  }
};

/// The fragment of each tet of a body that is one piece of one tet.
const std::vector<Index> kOneFragment{0};

TEST(StandInSpheres, ABareTetGetsOneSphereAtItsSolidsCentreThatFitsInsideIt) {
  const OneTet tet;
  MassDistribution mass{{0.5}, {Vec4(0.4, 0.3, 0.2, 0.1)}};
  StandInSpheres stand_ins(tet.rest, tet.tets, EmbeddedPoints{}, &mass);
  EXPECT_EQ(stand_ins.reserved(), 1u);
  EmbeddedPoints points;
  const std::vector<TetFace> exposed{{0, 2}, {0, 3}};  // two faces of the same tet: one sphere
  EXPECT_EQ(stand_ins.add_for(exposed, tet.tets, kOneFragment, points), 1u);
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points.barycentric[0], mass.center_of_mass[0]);
  const Vec3 centre = tet.rest * points.barycentric[0];
  double nearest = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 4; ++i) nearest = std::min(nearest, tet.inside_distance(centre, i));
  // As large as fits at the centre, scaled by the cube root of the solid fraction.
  EXPECT_NEAR(points.radius[0], std::cbrt(0.5) * nearest, 1e-12 * nearest);
  EXPECT_EQ(stand_ins.reserved(), 0u);
  EXPECT_EQ(stand_ins.add_for(exposed, tet.tets, kOneFragment, points), 0u) << "a reserve is spent once";
}

// A sliver of solid along a face has its centre of mass on that face, where no sphere
// fits: its reserve had radius 0, so it got no sphere at all. It now sits halfway to the
// centroid, inside the tet, at least half as large as the centroid's would be.
TEST(StandInSpheres, ASliverOfSolidOnAFaceStillGetsASphereInsideTheTet) {
  const OneTet tet;
  MassDistribution mass{{1e-4}, {Vec4(0.5, 0.3, 0.2, 0.0)}};  // on the face opposite corner 3
  StandInSpheres stand_ins(tet.rest, tet.tets, EmbeddedPoints{}, &mass);
  EmbeddedPoints points;
  ASSERT_EQ(stand_ins.add_for(std::vector<TetFace>{{0, 3}}, tet.tets, kOneFragment, points), 1u);
  const Vec4 halfway = 0.5 * (mass.center_of_mass[0] + Vec4::Constant(0.25));
  EXPECT_TRUE(points.barycentric[0].isApprox(halfway, 1e-15));
  const Vec3 centre = tet.rest * points.barycentric[0], centroid = tet.rest * Vec4::Constant(0.25);
  double nearest = std::numeric_limits<double>::infinity(), at_centroid = nearest;
  for (int i = 0; i < 4; ++i) {
    nearest = std::min(nearest, tet.inside_distance(centre, i));
    at_centroid = std::min(at_centroid, tet.inside_distance(centroid, i));
  }
  EXPECT_NEAR(points.radius[0], std::cbrt(1e-4) * nearest, 1e-12 * nearest);
  EXPECT_GE(nearest, 0.5 * at_centroid);
}

TEST(StandInSpheres, TetsWithPointsOrWithoutSolidHaveNoReserve) {
  const OneTet tet;
  EmbeddedPoints baked;
  baked.tet = {0};
  baked.barycentric = {Vec4::Constant(0.25)};
  baked.radius = {0.01};
  EXPECT_EQ(StandInSpheres(tet.rest, tet.tets, baked, nullptr).reserved(), 0u);
  MassDistribution empty{{0.0}, {Vec4::Constant(0.25)}};
  EXPECT_EQ(StandInSpheres(tet.rest, tet.tets, EmbeddedPoints{}, &empty).reserved(), 0u);
  // Without a mass distribution every tet holds solid; at the centroid the sphere is
  // the inscribed_spheres() one.
  StandInSpheres uniform(tet.rest, tet.tets, EmbeddedPoints{}, nullptr);
  EmbeddedPoints points;
  ASSERT_EQ(uniform.add_for(std::vector<TetFace>{{0, 1}}, tet.tets, kOneFragment, points), 1u);
  EXPECT_NEAR(points.radius[0], inscribed_spheres(tet.rest, tet.tets).radius[0], 1e-15);
}

TEST(StandInSpheres, TruncatingPutsTheReservesBack) {
  const OneTet tet;
  StandInSpheres stand_ins(tet.rest, tet.tets, EmbeddedPoints{}, nullptr);
  EmbeddedPoints points;
  ASSERT_EQ(stand_ins.add_for(std::vector<TetFace>{{0, 0}}, tet.tets, kOneFragment, points), 1u);
  const double radius = points.radius[0];
  stand_ins.truncate(points, 0);
  EXPECT_EQ(points.size(), 0u);
  EXPECT_EQ(stand_ins.reserved(), 1u);
  ASSERT_EQ(stand_ins.add_for(std::vector<TetFace>{{0, 0}}, tet.tets, kOneFragment, points), 1u);
  EXPECT_EQ(points.radius[0], radius);
}

// Issue 42: a reserve sphere covers a render vertex that a sphere of its cover tet
// covers while the two are joined. Tets 0 and 1 share a face, tet 2 is apart. Reserve A
// (tet 0, cover 1) comes when a split parts tets 0 and 1, not when a crack only exposes
// tet 0; B (tet 1, cover 2, sharing no node) and C (tet 2, no cover) come with their
// tets' exposure. Each once; a rolled-back step takes back exactly what it added.
TEST(StandInSpheres, AReserveSphereComesWhenASplitPartsItsTetFromItsCover) {
  Matrix3Xd rest = Matrix3Xd::Random(3, 9);
  Matrix4Xu tets(4, 3);
  tets << 0, 1, 5,  //
      1, 2, 6,      //
      2, 3, 7,      //
      3, 4, 8;
  EmbeddedPoints baked;  // every tet has a sphere: no stand-ins
  baked.tet = {0, 1, 2};
  baked.barycentric.assign(3, Vec4::Constant(0.25));
  baked.radius = {0.01, 0.01, 0.01};
  EmbeddedPoints reserve;
  reserve.tet = {0, 1, 2};
  reserve.barycentric = {Vec4(0.7, 0.1, 0.1, 0.1), Vec4(0.1, 0.1, 0.1, 0.7), Vec4(0.1, 0.7, 0.1, 0.1)};
  reserve.radius = {0.002, 0.003, 0.004};
  StandInSpheres stand_ins(rest, tets, baked, nullptr, reserve, std::vector<TetIndex>{1, 2, kInvalidIndex});
  EXPECT_EQ(stand_ins.reserved(), 3u);
  EmbeddedPoints points = baked;
  const std::vector<Index> one_piece{0, 0, 0};
  EXPECT_EQ(stand_ins.add_for(std::vector<TetFace>{{0, 0}}, tets, one_piece, points), 0u)
      << "a crack that exposes tet 0 but leaves it joined to tet 1";
  Matrix4Xu split = tets;
  split(0, 1) = 9;  // tet 1's copy of node 1: tets 0 and 1 now share 2 nodes
  ASSERT_EQ(stand_ins.add_for(std::vector<TetFace>{{1, 3}}, split, one_piece, points), 2u);
  EXPECT_EQ(points.radius[3], 0.003) << "B, with its tet's exposure";
  EXPECT_EQ(points.radius[4], 0.002) << "A, parted from its cover";
  EXPECT_EQ(points.barycentric[4], reserve.barycentric[0]);
  ASSERT_EQ(stand_ins.add_for(std::vector<TetFace>{{2, 0}}, split, one_piece, points), 1u);
  EXPECT_EQ(points.radius[5], 0.004);
  EXPECT_EQ(stand_ins.add_for(std::vector<TetFace>{{0, 1}, {1, 1}, {2, 1}}, split, one_piece, points), 0u);
  EXPECT_EQ(stand_ins.reserved(), 0u);
  // Reserve spheres meet obstacles only; the baked spheres stay as they were.
  EXPECT_EQ(stand_ins.obstacles_only(), (std::vector<std::uint8_t>{0, 0, 0, 1, 1, 1}));
  stand_ins.truncate(points, 4);
  EXPECT_EQ(points.size(), 4u);
  EXPECT_EQ(stand_ins.obstacles_only().size(), 4u);
  EXPECT_EQ(stand_ins.reserved(), 2u);
  ASSERT_EQ(stand_ins.add_for(std::vector<TetFace>{{2, 0}}, split, one_piece, points), 2u);
  EXPECT_EQ(points.radius[4], 0.004);
  EXPECT_EQ(points.radius[5], 0.002);
}

// The hole this closes (issue 16): the bake culls the spheres deep inside a solid, so a
// crack through that interior made fragments with no collision point, and they fell
// through the ground (the sample bunny at toughness 0: nodes 0.9 m below it after 110
// steps). Here a 4×1×1 bar has spheres only in its end cubes and shatters at toughness 0
// as it lands: every piece, the bare middle's included, must stay on the ground.
TEST(StandInSpheres, FragmentsOfBareTetsStayOnTheGround) {
  const TetMesh cage = testing::grid_cage(Vec3(0, 0, 0.02), Vec3(0.4, 0.1, 0.12), 4, 1, 1);
  BodyDescription body = testing::describe("bar", cage, Material{.density = 1000, .youngs_modulus = 2e5, .poisson_ratio = 0.3});
  body.toughness = 0.0;
  const EmbeddedPoints all = inscribed_spheres(cage.rest_positions, cage.tets);
  for (std::size_t k = 0; k < all.size(); ++k) {
    double x = 0.0;
    for (int i = 0; i < 4; ++i) x += 0.25 * cage.rest_positions(0, cage.tets(i, all.tet[k]));
    if (x > 0.1 && x < 0.3) continue;  // the middle two cubes are bare, as if culled
    body.spheres.tet.push_back(all.tet[k]);
    body.spheres.barycentric.push_back(all.barycentric[k]);
    body.spheres.radius.push_back(all.radius[k]);
  }
  const std::size_t baked = body.spheres.size();
  ASSERT_EQ(baked, all.size() / 2);
  body.velocity = Matrix3Xd::Zero(3, cage.rest_positions.cols());
  body.velocity.row(2).setConstant(-2.0);
  Environment environment;
  environment.ground = Plane{};  // z = 0, z up, as gravity
  WorldSettings settings;
  settings.fracture = true;
  settings.self_collision = true;
  World world({body}, environment, {}, settings);
  int stand_ins = 0;
  for (int i = 0; i < 120; ++i) stand_ins += world.step().stand_in_spheres;
  const Matrix3Xd& x = world.bodies()[0].integrator().positions();
  std::printf("%u fragments, %d stand-in spheres; lowest node %.4g m\n", world.fragment_count(), stand_ins,
              x.row(2).minCoeff());
  EXPECT_GT(world.fragment_count(), 4u);
  EXPECT_GT(stand_ins, 0);
  EXPECT_EQ(world.bodies()[0].spheres.size(), baked + static_cast<std::size_t>(stand_ins));
  // A one-tet fragment rests on its sphere; its corners may reach below the ground by
  // less than the tet's size (0.1 m). Falling freely it would be 1.9 m down.
  EXPECT_GT(x.row(2).minCoeff(), -0.1);
}

}  // namespace
}  // namespace fissure::sim
