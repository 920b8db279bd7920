#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <map>

#include "bake/bake.h"
#include "bake/winding_number.h"
#include "common/barycentric.h"
#include "common/error.h"
#include "formats/bundle_checks.h"
#include "formats/cage_io.h"
#include "tests/support/procedural.h"
#include "tests/support/temp_dir.h"

namespace fissure::bake {
namespace {

using formats::Bundle;
using formats::TetClass;

/// The embedding stage only (walls and collision have their own tests).
BakeOptions embedding_only() {
  BakeOptions options;
  options.walls = options.collision = false;
  return options;
}

Bundle embed_quietly(const SurfaceMesh& mesh, const TetMesh& cage) {
  return embed(mesh, cage, embedding_only(), "mesh", "cage");
}

void expect_verified(const Bundle& bundle, const std::string& what) {
  const formats::VerifyReport report = formats::verify_bundle(bundle);
  for (const auto& check : report.checks) EXPECT_TRUE(check.passed) << what << ": " << check.name << ": " << check.detail;
}

struct Case {
  std::string name;
  SurfaceMesh mesh;
  TetMesh cage;
};

std::vector<Case> procedural_cases() {
  const Vec3 lo(-1.37, -1.41, -1.33), hi(1.39, 1.35, 1.43);
  return {
      {"sphere", testing::icosphere(3, 1.0), testing::grid_cage(lo, hi, 4, 5, 3)},
      {"torus", testing::torus(0.9, 0.35, 48, 24), testing::grid_cage(lo, hi, 5, 5, 2)},
      {"box", testing::box_surface(Vec3(-0.93, -0.71, -0.52), Vec3(0.88, 0.67, 0.91), 6), testing::grid_cage(lo, hi, 3, 4, 5)},
      // Box faces exactly on grid planes: triangles coplanar with cage faces.
      {"aligned-box", testing::box_surface(Vec3(-0.5, -0.5, -0.5), Vec3(0.5, 0.5, 0.5), 4),
       testing::grid_cage(Vec3(-1, -1, -1), Vec3(1, 1, 1), 4, 4, 4)},
  };
}

TEST(Embedding, ProceduralMeshesInGridCagesSatisfyEveryInvariant) {
  for (const Case& c : procedural_cases()) {
    const Bundle bundle = embed_quietly(c.mesh, c.cage);
    EXPECT_GE(bundle.embedding.instance_count(), c.mesh.triangle_count()) << c.name;
    expect_verified(bundle, c.name);
  }
}

TEST(Embedding, CoplanarTrianglesAreStoredOncePerFace) {
  // Every triangle of the aligned box lies in grid planes: it is assigned to the tets
  // behind it only, so replication equals the number of tets its area really spans.
  const Case c = procedural_cases()[3];
  const Bundle bundle = embed_quietly(c.mesh, c.cage);
  const auto covered = formats::covered_area(bundle.render, bundle.cage, bundle.embedding);
  for (Index t = 0; t < c.mesh.triangle_count(); ++t) {
    EXPECT_NEAR(covered[t], triangle_area(c.mesh, t), 1e-12 * triangle_area(c.mesh, t)) << "triangle " << t;
  }
}

TEST(Embedding, BunnyInSharedCagesSatisfiesEveryInvariant) {
  const auto mesh = import_render_mesh(testing::data_dir() / "meshes" / "bunny-5k.obj").mesh;
  for (const char* cage_name : {"bunny-5k-cage-10.node", "bunny-5k-cage-100.node", "bunny-5k-cage-987.node"}) {
    const auto cage = formats::read_cage(testing::data_dir() / "cages" / cage_name);
    expect_verified(embed_quietly(mesh, cage.mesh), cage_name);
  }
}

TEST(Embedding, NodeClassificationMatchesTheSphere) {
  const SurfaceMesh sphere = testing::icosphere(4, 1.0);
  const TetMesh cage = testing::grid_cage(Vec3::Constant(-1.5), Vec3::Constant(1.5), 7, 7, 7);
  const Bundle bundle = embed_quietly(sphere, cage);
  std::size_t checked = 0;
  for (Index n = 0; n < cage.node_count(); ++n) {
    const double r = cage.rest_positions.col(n).norm();
    if (std::abs(r - 1.0) < 0.01) continue;  // the icosphere is within 0.1% of the sphere
    EXPECT_EQ(bundle.embedding.node_inside[n] != 0, r < 1.0) << "node " << n << " at radius " << r;
    ++checked;
  }
  EXPECT_GT(checked, cage.node_count() / 2);
  for (Index t = 0; t < cage.tet_count(); ++t) {
    double min_r = 1e9, max_r = 0;
    for (int k = 0; k < 4; ++k) {
      const double r = cage.rest_positions.col(cage.tets(k, t)).norm();
      min_r = std::min(min_r, r);
      max_r = std::max(max_r, r);
    }
    if (max_r < 0.99) {
      EXPECT_EQ(bundle.embedding.tet_class[t], TetClass::Inside) << "tet " << t;
    }
    // Not touching the ball of radius 1 (using the distance from the centre to the tet's
    // bounding sphere is enough for grid tets here): outside.
    if (min_r > 1.0 + 0.01 + (cage.rest_positions.col(cage.tets(0, t)) - cage.rest_positions.col(cage.tets(3, t))).norm()) {
      EXPECT_EQ(bundle.embedding.tet_class[t], TetClass::Outside) << "tet " << t;
    }
  }
}

TEST(Embedding, OpenBunnyStillBakesAndAgreesWithTheClosedOne) {
  const auto closed = import_render_mesh(testing::data_dir() / "meshes" / "bunny-5k.obj").mesh;
  const auto open = import_render_mesh(testing::data_dir() / "meshes" / "bunny-5k-open.obj").mesh;
  const auto cage = formats::read_cage(testing::data_dir() / "cages" / "bunny-5k-cage-987.node");
  BakeStats stats;
  const Bundle open_bundle = embed(open, cage.mesh, embedding_only(), "open", "cage", &stats);
  EXPECT_EQ(stats.boundary_loops, 5u);
  expect_verified(open_bundle, "open bunny");
  const Bundle closed_bundle = embed_quietly(closed, cage.mesh);
  std::size_t agree = 0;
  for (Index n = 0; n < cage.mesh.node_count(); ++n) {
    agree += open_bundle.embedding.node_inside[n] == closed_bundle.embedding.node_inside[n];
  }
  // The two scans differ only at the base (holes vs. filled): nearly every node agrees.
  EXPECT_GE(agree, cage.mesh.node_count() * 97 / 100) << agree << " of " << cage.mesh.node_count();
}

TEST(Embedding, ContourSegmentsLieOnTheirFaceAndTriangle) {
  const Case c = procedural_cases()[0];
  const Bundle b = embed_quietly(c.mesh, c.cage);
  const auto& e = b.embedding;
  ASSERT_GT(e.segment_count(), 0u);
  for (FaceIndex f = 0; f < b.faces.face_count(); ++f) {
    const Vec3 a = b.cage.rest_positions.col(b.faces.nodes(0, f));
    const Vec3 u = b.cage.rest_positions.col(b.faces.nodes(1, f)) - a;
    const Vec3 v = b.cage.rest_positions.col(b.faces.nodes(2, f)) - a;
    const Vec3 n = u.cross(v);
    for (std::uint64_t s = e.contour_offsets[f]; s < e.contour_offsets[f + 1]; ++s) {
      const TriangleIndex t = e.contour_triangle[s];
      const Vec3 ta = b.render.positions.col(b.render.triangles(0, t));
      const Vec3 tu = b.render.positions.col(b.render.triangles(1, t)) - ta;
      const Vec3 tv = b.render.positions.col(b.render.triangles(2, t)) - ta;
      for (int k = 0; k < 2; ++k) {
        const Vec3 p = e.contour_points[s].col(k);
        EXPECT_NEAR(n.normalized().dot(p - a), 0.0, 1e-14);
        EXPECT_NEAR(tu.cross(tv).normalized().dot(p - ta), 0.0, 1e-14);
        // Inside the face triangle and the render triangle (2D barycentrics ≥ 0).
        for (const auto& [origin, e1, e2] : {std::tuple{a, u, v}, std::tuple{ta, tu, tv}}) {
          Eigen::Matrix<double, 3, 2> basis;
          basis << e1, e2;
          const Vec2 st = basis.colPivHouseholderQr().solve(p - origin);
          EXPECT_GE(st.x(), -1e-12);
          EXPECT_GE(st.y(), -1e-12);
          EXPECT_LE(st.sum(), 1.0 + 1e-12);
        }
      }
    }
  }
}

TEST(Embedding, ContoursOfAClosedSurfaceFormChains) {
  // On a closed surface, a contour end point strictly inside a face is shared by exactly
  // one other segment of that face (the neighbouring triangle's), bit for bit, because
  // both are the same exact point rounded once.
  const Case c = procedural_cases()[1];
  const Bundle b = embed_quietly(c.mesh, c.cage);
  const auto& e = b.embedding;
  ASSERT_GT(e.segment_count(), 100u);
  for (FaceIndex f = 0; f < b.faces.face_count(); ++f) {
    std::map<std::tuple<double, double, double>, int> ends;
    for (std::uint64_t s = e.contour_offsets[f]; s < e.contour_offsets[f + 1]; ++s) {
      for (int k = 0; k < 2; ++k) {
        const Vec3 p = e.contour_points[s].col(k);
        ends[{p.x(), p.y(), p.z()}] += k == 0 ? 1 : -1;  // heads and tails
      }
    }
    const Vec3 a = b.cage.rest_positions.col(b.faces.nodes(0, f));
    const Vec3 bb = b.cage.rest_positions.col(b.faces.nodes(1, f));
    const Vec3 cc = b.cage.rest_positions.col(b.faces.nodes(2, f));
    for (const auto& [key, balance] : ends) {
      const Vec3 p(std::get<0>(key), std::get<1>(key), std::get<2>(key));
      const double to_edge = std::min({(p - a).cross(bb - a).norm() / (bb - a).norm(),
                                       (p - bb).cross(cc - bb).norm() / (cc - bb).norm(),
                                       (p - cc).cross(a - cc).norm() / (a - cc).norm()});
      // Interior points: one head and one tail (consistent orientation along the chain).
      if (to_edge > 1e-9) {
        EXPECT_EQ(balance, 0) << "face " << f << " point " << p.transpose() << " to_edge " << to_edge;
      }
    }
  }
}

TEST(Embedding, ContoursHaveTheSolidOnTheirLeft) {
  const Case c = procedural_cases()[0];
  const Bundle b = embed_quietly(c.mesh, c.cage);
  const WindingNumberTree winding(c.mesh);
  const auto& e = b.embedding;
  std::size_t checked = 0;
  for (FaceIndex f = 0; f < b.faces.face_count(); ++f) {
    const Vec3 a = b.cage.rest_positions.col(b.faces.nodes(0, f));
    const Vec3 n = (b.cage.rest_positions.col(b.faces.nodes(1, f)) - a)
                       .cross(b.cage.rest_positions.col(b.faces.nodes(2, f)) - a)
                       .normalized();
    for (std::uint64_t s = e.contour_offsets[f]; s < e.contour_offsets[f + 1]; ++s) {
      const Vec3 p = e.contour_points[s].col(0), q = e.contour_points[s].col(1);
      if ((q - p).norm() < 1e-3) continue;  // too short to probe beside it robustly
      const Vec3 mid = 0.5 * (p + q);
      const Vec3 left = n.cross((q - p).normalized());
      EXPECT_GT(winding.winding_number_direct(mid + 1e-4 * left), 0.5) << "face " << f << " segment " << s;
      EXPECT_LT(winding.winding_number_direct(mid - 1e-4 * left), 0.5) << "face " << f << " segment " << s;
      ++checked;
    }
  }
  EXPECT_GT(checked, 100u);
}

TEST(Embedding, CageThatMissesPartOfTheMeshIsAnErrorSayingWhere) {
  // Inside the cage's bounding box but outside its tets: the coverage check finds it.
  const SurfaceMesh concave = testing::icosphere(3, 1.0);
  TetMesh cage_with_a_hole = testing::grid_cage(Vec3(-1.2, -1.2, -1.2), Vec3(1.2, 1.2, 1.2), 4, 4, 4);
  {  // drop the tets of the cell x ∈ [0.6, 1.2], y, z ∈ [0, 0.6], which the sphere passes through
    Matrix4Xu kept(4, 0);
    for (Eigen::Index t = 0; t < cage_with_a_hole.tets.cols(); ++t) {
      Vec3 centroid = Vec3::Zero();
      for (int k = 0; k < 4; ++k) centroid += cage_with_a_hole.rest_positions.col(cage_with_a_hole.tets(k, t)) / 4.0;
      if (centroid.x() > 0.6 && centroid.y() > 0 && centroid.y() < 0.6 && centroid.z() > 0 && centroid.z() < 0.6) continue;
      kept.conservativeResize(4, kept.cols() + 1);
      kept.col(kept.cols() - 1) = cage_with_a_hole.tets.col(t);
    }
    ASSERT_LT(kept.cols(), cage_with_a_hole.tets.cols());
    cage_with_a_hole.tets = kept;
  }
  testing::expect_error_containing([&] { embed(concave, cage_with_a_hole, BakeOptions{}, "sphere.obj", "holed.node"); },
                                   {"holed.node does not cover sphere.obj", "triangles lie partly or wholly outside",
                                    "area", "within the box (", "enlarge the cage"});
  // Outside the bounding box: found before the embedding, naming the first vertex.
  const SurfaceMesh sphere = testing::icosphere(3, 1.0);
  // The grid stops at x = 0.8: the cap beyond it is outside.
  const TetMesh cage = testing::grid_cage(Vec3(-1.2, -1.2, -1.2), Vec3(0.8, 1.2, 1.2), 4, 4, 4);
  testing::expect_error_containing([&] { embed(sphere, cage, BakeOptions{}, "sphere.obj", "small.node"); },
                                   {"small.node does not cover sphere.obj", "vertices lie outside the cage's bounding box",
                                    "within the box (", "first: vertex", "enlarge the cage"});
}

TEST(Embedding, DeterministicWhateverTheThreadCount) {
  const Case c = procedural_cases()[1];
  Bundle one, two;
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = embed_quietly(c.mesh, c.cage);
  }
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 4);
    two = embed_quietly(c.mesh, c.cage);
  }
  testing::TempDir dir;
  formats::write_bundle(dir / "one.h5", one);
  formats::write_bundle(dir / "two.h5", two);
  std::ifstream a(dir / "one.h5", std::ios::binary), b(dir / "two.h5", std::ios::binary);
  const std::string bytes_a{std::istreambuf_iterator<char>(a), {}}, bytes_b{std::istreambuf_iterator<char>(b), {}};
  EXPECT_FALSE(bytes_a.empty());
  EXPECT_EQ(bytes_a, bytes_b);
}

}  // namespace
}  // namespace fissure::bake
