#include "bake/collision_proxies.h"

#include <gtest/gtest.h>

#include <set>
#include <tuple>

#include "bake/bake.h"
#include "common/error.h"
#include "common/barycentric.h"
#include "formats/bundle_checks.h"
#include "formats/vertex_instances.h"
#include "tests/support/procedural.h"
#include "tests/support/temp_dir.h"

namespace fissure::bake {
namespace {

formats::Bundle bake_collision_only(const SurfaceMesh& mesh, const TetMesh& cage, SphereOptions spheres,
                                    CollisionStats* stats = nullptr) {
  BakeOptions options;
  options.walls = false;
  options.spheres = spheres;
  BakeStats bake_stats;
  formats::Bundle bundle = embed(mesh, cage, options, "mesh", "cage", &bake_stats);
  if (stats) *stats = bake_stats.collision;
  return bundle;
}

Vec3 sphere_centre(const formats::Bundle& b, std::size_t s) {
  Eigen::Matrix<double, 3, 4> nodes;
  for (int i = 0; i < 4; ++i) nodes.col(i) = b.cage.rest_positions.col(b.cage.tets(i, b.collision->sphere_tet[s]));
  return nodes * b.collision->sphere_barycentric[s];
}

TEST(CollisionSpheres, GridSpheresAreInsideTheirTetsAndSurfaceSpheresReachTheSurfaceFromInside) {
  const SurfaceMesh sphere = testing::icosphere(3, 1.0);
  const TetMesh cage = testing::grid_cage(Vec3::Constant(-1.3), Vec3::Constant(1.3), 4, 4, 4);
  CollisionStats stats;
  const formats::Bundle b = bake_collision_only(sphere, cage, SphereOptions{.radius = 0.08}, &stats);
  const WindingNumberTree winding(sphere);
  const std::size_t count = b.collision->sphere_tet.size();
  ASSERT_GT(stats.surface, 50u);
  ASSERT_GT(count, stats.surface + 50u);
  std::size_t inside_tet = 0, reaching = 0;
  for (std::size_t s = 0; s < count; ++s) {
    EXPECT_GE(winding.winding_number_direct(sphere_centre(b, s)), 0.5) << "sphere " << s;
    if (s > 0) {
      EXPECT_LE(b.collision->sphere_tet[s - 1], b.collision->sphere_tet[s]) << "sorted by tet (bundle schema)";
    }
    // The icosphere's surface is within 1.3 % of the unit sphere: no sphere pokes out of
    // it, and the surface spheres' lowest points reach it.
    const double outermost = sphere_centre(b, s).norm() + b.collision->sphere_radius[s];
    EXPECT_LE(outermost, 1.015) << "sphere " << s;
    reaching += outermost >= 0.985;
    inside_tet += b.collision->sphere_barycentric[s].minCoeff() >= 0.0;
  }
  EXPECT_GE(reaching, stats.surface);
  EXPECT_GE(inside_tet, count - stats.surface);  // every grid sphere, and the surface ones centred in their own tet
  EXPECT_EQ(stats.surface_shrunk, 0u);  // radius 0.08 fits a unit ball everywhere
  for (const formats::VerifyCheck& check : formats::verify_bundle(b).checks) {
    if (check.name == "collision-spheres") {
      EXPECT_TRUE(check.passed) << check.detail;
    }
  }
}

TEST(CollisionSpheres, SurfaceSpheresCoverEveryRenderVertex) {
  // Every render vertex lies close to some sphere's surface: the whole body's cover
  // (issue 42). What a single tet carries alone is the reserve's test below.
  const SurfaceMesh sphere = testing::icosphere(3, 1.0);
  const TetMesh cage = testing::grid_cage(Vec3::Constant(-1.3), Vec3::Constant(1.3), 4, 4, 4);
  const double r = 0.08;
  const auto worst_gap = [&](double spacing) {
    const formats::Bundle b = bake_collision_only(sphere, cage, SphereOptions{.radius = r, .surface_spacing = spacing});
    double worst = 0.0;
    for (Index v = 0; v < sphere.vertex_count(); ++v) {
      const Vec3 p = sphere.positions.col(v);
      double gap = std::numeric_limits<double>::infinity();
      for (std::size_t s = 0; s < b.collision->sphere_tet.size(); ++s) {
        gap = std::min(gap, (sphere_centre(b, s) - p).norm() - b.collision->sphere_radius[s]);
      }
      worst = std::max(worst, gap);
    }
    return worst;
  };
  // Samples about r apart, each sphere touching the surface: the surface sags at most
  // about 0.3 r between them (a grid alone left up to a cell, 2 r). At the default
  // spacing of 2 r, samples up to about 2 r apart: at most about 0.7 r.
  EXPECT_LT(worst_gap(1.0), 0.35 * r);
  EXPECT_LT(worst_gap(2.0), 0.75 * r);
}

// Issue 42: fracture can free a single tet, which keeps only its own spheres. With its
// reserve, every render vertex is within kReserveGapShare r of a sphere of the tet that
// moves it (the player's rule, formats::vertex_instances); without, a coarse cage leaves
// vertices whose only cover is a neighbour's sphere. A reserve sphere's cover tet holds a
// sphere at least as near its vertex as the gap. The reserve survives the bundle file.
TEST(CollisionSpheres, ReserveSpheresCoverEveryRenderVertexByTheTetThatMovesIt) {
  const SurfaceMesh sphere = testing::icosphere(3, 1.0);
  const TetMesh cage = testing::grid_cage(Vec3::Constant(-1.3), Vec3::Constant(1.3), 3, 3, 3);
  const double r = 0.08, gap = kReserveGapShare * r;
  CollisionStats stats;
  const formats::Bundle b = bake_collision_only(sphere, cage, SphereOptions{.radius = r}, &stats);
  const formats::Collision& c = *b.collision;
  ASSERT_EQ(stats.reserve, c.reserve_tet.size());
  ASSERT_GT(c.reserve_tet.size(), 20u);
  const auto centre = [&](TetIndex t, const Vec4& beta) {
    Eigen::Matrix<double, 3, 4> nodes;
    for (int i = 0; i < 4; ++i) nodes.col(i) = b.cage.rest_positions.col(b.cage.tets(i, t));
    return Vec3(nodes * beta);
  };
  // From p to the nearest sphere surface of tet t (any tet: kInvalidIndex), with or
  // without the reserve.
  const auto gap_to = [&](const Vec3& p, TetIndex t, bool reserve) {
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t s = 0; s < c.sphere_tet.size(); ++s) {
      if (t != kInvalidIndex && c.sphere_tet[s] != t) continue;
      nearest = std::min(nearest, (centre(c.sphere_tet[s], c.sphere_barycentric[s]) - p).norm() - c.sphere_radius[s]);
    }
    for (std::size_t s = 0; reserve && s < c.reserve_tet.size(); ++s) {
      if (c.reserve_tet[s] != t) continue;
      nearest = std::min(nearest, (centre(c.reserve_tet[s], c.reserve_barycentric[s]) - p).norm() - c.reserve_radius[s]);
    }
    return nearest;
  };
  double worst_with = 0.0, worst_without = 0.0;
  const std::vector<formats::VertexInstance> held = formats::vertex_instances(b);
  for (Index v = 0; v < sphere.vertex_count(); ++v) {
    const TetIndex t = b.embedding.instance_tet[held[v].instance];
    const Vec3 p = sphere.positions.col(v);
    worst_with = std::max(worst_with, gap_to(p, t, true));
    worst_without = std::max(worst_without, gap_to(p, t, false));
  }
  EXPECT_LE(worst_with, gap * (1 + 1e-9));
  EXPECT_GT(worst_without, 2.0 * gap) << "the case needs the reserve";
  for (std::size_t s = 0; s < c.reserve_tet.size(); ++s) {
    if (s > 0) {
      EXPECT_LE(c.reserve_tet[s - 1], c.reserve_tet[s]) << "sorted by tet (bundle schema)";
    }
    if (c.reserve_cover_tet[s] == kInvalidIndex) continue;
    EXPECT_NE(c.reserve_cover_tet[s], c.reserve_tet[s]);
    // The reserve sphere touches its vertex, so the cover tet's sphere is within
    // 2 gap + 2 r of its centre.
    EXPECT_LE(gap_to(centre(c.reserve_tet[s], c.reserve_barycentric[s]), c.reserve_cover_tet[s], false),
              c.reserve_radius[s] + 1.5 * gap)
        << "reserve sphere " << s;
  }
  for (const formats::VerifyCheck& check : formats::verify_bundle(b).checks) {
    if (check.name == "collision-spheres") {
      EXPECT_TRUE(check.passed) << check.detail;
    }
  }
  testing::TempDir dir;
  formats::write_bundle(dir / "b.h5", b);
  const formats::Collision read = *formats::read_bundle(dir / "b.h5").collision;
  EXPECT_EQ(read.reserve_tet, c.reserve_tet);
  EXPECT_EQ(read.reserve_barycentric, c.reserve_barycentric);
  EXPECT_EQ(read.reserve_radius, c.reserve_radius);
  EXPECT_EQ(read.reserve_cover_tet, c.reserve_cover_tet);
}

TEST(CollisionSpheres, SurfaceSpheresShrinkToFitAThinPartAndNeverPokeOut) {
  // A slab 0.1 thick with r = 0.08: a sphere centred r inside one face would reach 0.06
  // out of the other. Halved (0.04), it fits: centred 0.04 in, 0.06 from the far face.
  const double half = 0.05, r = 0.08;
  const SurfaceMesh slab = testing::box_surface(Vec3(-1, -1, -half), Vec3(1, 1, half), 8);
  const TetMesh cage = testing::grid_cage(Vec3(-1.2, -1.2, -0.3), Vec3(1.2, 1.2, 0.3), 4, 4, 2);
  CollisionStats stats;
  const formats::Bundle b = bake_collision_only(slab, cage, SphereOptions{.radius = r}, &stats);
  ASSERT_GT(stats.surface, 100u);
  EXPECT_EQ(stats.surface_shrunk, stats.surface);  // every face sample had to shrink
  for (std::size_t s = 0; s < b.collision->sphere_tet.size(); ++s) {
    const Vec3 c = sphere_centre(b, s);
    const double radius = b.collision->sphere_radius[s];
    EXPECT_LE(std::abs(c.z()) + radius, half + 1e-9) << "sphere " << s << " pokes out of the slab";
    EXPECT_LE(c.cwiseAbs().head<2>().maxCoeff() + radius, 1.0 + 1e-9) << "sphere " << s;
  }
}

TEST(CollisionSpheres, AFinerCageDoesNotMultiplyTheSpheres) {
  // The radius follows the mesh, not the cage, and no tet halves it: 8 times the tets
  // give about as many spheres (the thesis's rule of 3 per tet multiplied them).
  const SurfaceMesh sphere = testing::icosphere(3, 1.0);
  const formats::Bundle coarse =
      bake_collision_only(sphere, testing::grid_cage(Vec3::Constant(-1.3), Vec3::Constant(1.3), 3, 3, 3), SphereOptions{});
  const formats::Bundle fine =
      bake_collision_only(sphere, testing::grid_cage(Vec3::Constant(-1.3), Vec3::Constant(1.3), 6, 6, 6), SphereOptions{});
  EXPECT_EQ(coarse.collision->target_radius, fine.collision->target_radius);
  EXPECT_NEAR(coarse.collision->target_radius, kRadiusPerSize * std::cbrt(4.0 / 3.0 * M_PI), 1e-3);
  const double ratio = static_cast<double>(fine.collision->sphere_tet.size()) / coarse.collision->sphere_tet.size();
  EXPECT_GT(ratio, 0.9);
  EXPECT_LT(ratio, 1.1);
}

// --surface-spacing: surface samples one per cell of that many radii, so twice the
// spacing gives about a quarter of the surface spheres; 0 gives none.
TEST(CollisionSpheres, SurfaceSpacingSetsHowManySurfaceSpheres) {
  const SurfaceMesh sphere = testing::icosphere(3, 1.0);
  const TetMesh cage = testing::grid_cage(Vec3::Constant(-1.3), Vec3::Constant(1.3), 3, 3, 3);
  const auto count = [&](double spacing) {
    return bake_collision_only(sphere, cage, SphereOptions{.surface_spacing = spacing}).collision->sphere_tet.size();
  };
  const double none = static_cast<double>(count(0.0));
  const double fine = static_cast<double>(count(1.0)) - none, coarse = static_cast<double>(count(2.0)) - none;
  EXPECT_GT(fine, 100.0);
  EXPECT_GT(coarse / fine, 0.2);
  EXPECT_LT(coarse / fine, 0.35);
  EXPECT_THROW(validate(SphereOptions{.surface_spacing = 0.1}), Error);
  EXPECT_THROW(validate(SphereOptions{.surface_spacing = 17.0}), Error);
}

TEST(CollisionSpheres, CullingRemovesExactlyTheFullySurroundedSpheres) {
  const SurfaceMesh box = testing::box_surface(Vec3::Constant(-0.8), Vec3::Constant(0.8), 4);
  const TetMesh cage = testing::grid_cage(Vec3::Constant(-1), Vec3::Constant(1), 2, 2, 2);
  SphereOptions all{.radius = 0.05, .cull_surrounded = false, .surface_spacing = 0.0};
  SphereOptions culled = all;
  culled.cull_surrounded = true;
  const formats::Bundle full = bake_collision_only(box, cage, all);
  const formats::Bundle kept = bake_collision_only(box, cage, culled);
  // Rebuild integer grid coordinates from the centres (spacing 2r from the cage's min corner).
  auto keys = [](const formats::Bundle& b) {
    std::set<std::tuple<long, long, long>> out;
    for (std::size_t s = 0; s < b.collision->sphere_tet.size(); ++s) {
      const Vec3 g = (sphere_centre(b, s) - Vec3::Constant(-1)) / 0.1 - Vec3(0.5137, 0.5271, 0.5419);
      out.insert({std::lround(g.x()), std::lround(g.y()), std::lround(g.z())});
    }
    return out;
  };
  const auto all_keys = keys(full), kept_keys = keys(kept);
  ASSERT_EQ(all_keys.size(), full.collision->sphere_tet.size());
  std::size_t expected_kept = 0;
  for (const auto& [i, j, k] : all_keys) {
    bool surrounded = true;
    for (int d = 0; d < 27 && surrounded; ++d) {
      if (d == 13) continue;
      surrounded = all_keys.count({i + d % 3 - 1, j + (d / 3) % 3 - 1, k + d / 9 - 1}) > 0;
    }
    EXPECT_EQ(kept_keys.count({i, j, k}) > 0, !surrounded);
    expected_kept += !surrounded;
  }
  EXPECT_EQ(kept_keys.size(), expected_kept);
  EXPECT_LT(expected_kept, all_keys.size());  // the box interior is culled
}

TEST(MassProperties, CubeInACubeCageIsExact) {
  // A 1.2-wide cube in a 4×4×4 grid of 0.5 cells: some tets wholly inside, many cut.
  const SurfaceMesh cube = testing::box_surface(Vec3::Constant(-0.6), Vec3::Constant(0.6), 3);
  const TetMesh cage = testing::grid_cage(Vec3::Constant(-1), Vec3::Constant(1), 4, 4, 4);
  const formats::Bundle b = bake_collision_only(cube, cage, SphereOptions{});
  double volume = 0.0;
  Vec3 moment = Vec3::Zero();
  for (Index t = 0; t < cage.tet_count(); ++t) {
    const double f = b.collision->mass_fraction[t];
    ASSERT_GE(f, 0.0);
    ASSERT_LE(f, 1.0);
    Eigen::Matrix<double, 3, 4> nodes;
    for (int i = 0; i < 4; ++i) nodes.col(i) = cage.rest_positions.col(cage.tets(i, t));
    bool all_inside = true;
    for (int i = 0; i < 4; ++i) all_inside = all_inside && nodes.col(i).cwiseAbs().maxCoeff() <= 0.6;
    if (all_inside) {
      EXPECT_EQ(f, 1.0) << "tet " << t;
    }
    // Sampling check of the exact fraction on a fine barycentric lattice.
    int inside = 0, total = 0;
    const int n = 24;
    for (int a = 0; a <= n; ++a) {
      for (int bb = 0; a + bb <= n; ++bb) {
        for (int c = 0; a + bb + c <= n; ++c) {
          const Vec4 beta(n - a - bb - c, a, bb, c);
          const Vec3 x = nodes * (beta / n);
          inside += x.cwiseAbs().maxCoeff() < 0.6;
          ++total;
        }
      }
    }
    EXPECT_NEAR(f, static_cast<double>(inside) / total, 0.12) << "tet " << t;
    const double v = signed_volume(cage, t);
    volume += f * v;
    moment += f * v * (nodes * b.collision->center_of_mass[t]);
  }
  EXPECT_NEAR(volume, 1.2 * 1.2 * 1.2, 1e-12);
  EXPECT_LT(moment.norm(), 1e-12);  // symmetric about the origin
}

TEST(MassProperties, BadOptionsAreErrors) {
  EXPECT_THROW(validate(SphereOptions{.radius = -1.0}), Error);
  EXPECT_THROW(validate(SphereOptions{.radius = std::numeric_limits<double>::infinity()}), Error);
}

}  // namespace
}  // namespace fissure::bake
