#include "bake/walls.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "bake/bake.h"
#include "common/error.h"
#include "formats/bundle_checks.h"
#include "tests/support/procedural.h"
#include "tests/support/temp_dir.h"

namespace fissure::bake {
namespace {

/// A slab-topped box whose top face z = 0.3 cuts the middle of a 4×4×4 grid cage:
/// faces with every node at |x|, |y| ≤ 0.5 and z ≥ −0.5 meet only that plane, so their
/// inside region is exactly face ∩ {z ≤ 0.3}.
struct PlaneCase {
  SurfaceMesh mesh = testing::box_surface(Vec3(-0.9, -0.9, -0.9), Vec3(0.9, 0.9, 0.3), 6);
  TetMesh cage = testing::grid_cage(Vec3::Constant(-1), Vec3::Constant(1), 4, 4, 4);
};

bool in_middle(const formats::Bundle& b, FaceIndex f) {
  for (int k = 0; k < 3; ++k) {
    const Vec3 p = b.cage.rest_positions.col(b.faces.nodes(k, f));
    if (std::abs(p.x()) > 0.5 || std::abs(p.y()) > 0.5 || p.z() < -0.5) return false;
  }
  return true;
}

/// Area of the triangle's part below z = 0.3 (Sutherland–Hodgman on one plane).
double area_below(const Vec3& a, const Vec3& b, const Vec3& c, double z) {
  std::vector<Vec3> in{a, b, c}, out;
  for (std::size_t i = 0; i < in.size(); ++i) {
    const Vec3& p = in[i];
    const Vec3& q = in[(i + 1) % in.size()];
    if (p.z() <= z) out.push_back(p);
    if ((p.z() < z) != (q.z() < z) && p.z() != z && q.z() != z) out.push_back(p + (q - p) * ((z - p.z()) / (q.z() - p.z())));
  }
  double twice = 0.0;
  for (std::size_t i = 1; i + 1 < out.size(); ++i) twice += (out[i] - out[0]).cross(out[i + 1] - out[0]).norm();
  return 0.5 * twice;
}

formats::Bundle bake_plane_case(std::uint32_t resolution) {
  const PlaneCase c;
  BakeOptions options;
  options.collision = false;
  options.wall.resolution = resolution;
  return embed(c.mesh, c.cage, options, "slab", "grid");
}

TEST(Walls, InsideAreaOfAPlaneCutIsExact) {
  const formats::Bundle b = bake_plane_case(8);
  std::size_t checked = 0;
  for (FaceIndex f = 0; f < b.faces.face_count(); ++f) {
    if (!in_middle(b, f)) continue;
    const auto& p = b.cage.rest_positions;
    const double exact = area_below(p.col(b.faces.nodes(0, f)), p.col(b.faces.nodes(1, f)), p.col(b.faces.nodes(2, f)), 0.3);
    EXPECT_NEAR(b.walls->face_inside_area[f], exact, 1e-12) << "face " << f;
    const bool crossing = exact > 0.0 && exact < face_area(b.cage, b.faces, f) - 1e-12;
    EXPECT_EQ(b.walls->face_class[f], crossing ? formats::FaceClass::Crossing
                                               : (exact > 0.0 ? formats::FaceClass::Inside : formats::FaceClass::Outside))
        << "face " << f;
    ++checked;
  }
  EXPECT_GT(checked, 50u);
}

TEST(Walls, TileCoverageConvergesToTheExactAreaAsResolutionDoubles) {
  double first_scaled_error = -1.0;
  for (const std::uint32_t resolution : {8u, 16u, 32u, 64u, 128u, 256u}) {
    const formats::Bundle b = bake_plane_case(resolution);
    double total_error = 0.0;
    for (FaceIndex f = 0; f < b.faces.face_count(); ++f) {
      if (!in_middle(b, f) || b.walls->face_class[f] != formats::FaceClass::Crossing) continue;
      const double area = face_area(b.cage, b.faces, f);
      const double error = std::abs(formats::tile_inside_area(*b.walls, f, area) - b.walls->face_inside_area[f]);
      // About one texel row along the region's boundary (contour + face edges).
      const Vec3 n0 = b.cage.rest_positions.col(b.faces.nodes(0, f));
      const double e1 = (b.cage.rest_positions.col(b.faces.nodes(1, f)) - n0).norm();
      const double e2 = (b.cage.rest_positions.col(b.faces.nodes(2, f)) - n0).norm();
      const double texel = std::max(e1, e2) / resolution;
      EXPECT_LE(error, 4.0 * (e1 + e2) * texel) << "face " << f << " at " << resolution;
      total_error += error;
    }
    std::printf("resolution %u: total |tile area - exact| = %.3g\n", resolution, total_error);
    // First-order convergence: the error times the resolution stays bounded (it
    // wobbles as texel centres line up with the contour, but never grows).
    if (first_scaled_error < 0) first_scaled_error = total_error * resolution;
    EXPECT_LE(total_error * resolution, 1.25 * first_scaled_error) << "resolution " << resolution;
  }
}

TEST(Walls, SignedDistanceIsZeroOnTheContourWithinHalfATexel) {
  const formats::Bundle b = bake_plane_case(32);
  const formats::Walls& w = *b.walls;
  const auto& e = b.embedding;
  const double res = w.resolution;
  // One texel of distance is 127 / range byte steps.
  const double half_texel = 0.5 * 127.0 / w.sdf_range_texels;
  std::size_t checked = 0;
  for (FaceIndex f = 0; f < b.faces.face_count(); ++f) {
    if (w.face_tile[f] == kInvalidIndex) continue;
    const Vec3 n0 = b.cage.rest_positions.col(b.faces.nodes(0, f));
    Eigen::Matrix<double, 3, 2> basis;
    basis << b.cage.rest_positions.col(b.faces.nodes(1, f)) - n0, b.cage.rest_positions.col(b.faces.nodes(2, f)) - n0;
    const std::uint8_t* tile = &w.sdf[w.face_tile[f] * w.resolution * w.resolution];
    for (std::uint64_t s = e.contour_offsets[f]; s < e.contour_offsets[f + 1]; ++s) {
      for (const double t : {0.25, 0.5, 0.75}) {
        const Vec3 p = (1 - t) * e.contour_points[s].col(0) + t * e.contour_points[s].col(1);
        const Vec2 uv = basis.colPivHouseholderQr().solve(p - n0);
        // Bilinear filtering as the GPU does it, texel centres at (i + ½)/res.
        const double x = uv.x() * res - 0.5, y = uv.y() * res - 0.5;
        const int i = std::clamp(static_cast<int>(std::floor(x)), 0, static_cast<int>(res) - 2);
        const int j = std::clamp(static_cast<int>(std::floor(y)), 0, static_cast<int>(res) - 2);
        const double fx = std::clamp(x - i, 0.0, 1.0), fy = std::clamp(y - j, 0.0, 1.0);
        auto at = [&](int ii, int jj) { return static_cast<double>(tile[jj * static_cast<int>(res) + ii]); };
        const double value = (1 - fy) * ((1 - fx) * at(i, j) + fx * at(i + 1, j)) + fy * ((1 - fx) * at(i, j + 1) + fx * at(i + 1, j + 1));
        EXPECT_NEAR(value, 127.5, half_texel + 1.0) << "face " << f << " segment " << s;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 100u);
}

TEST(Walls, TexelCentresOnTheFaceAreClassifiedExactly) {
  const formats::Bundle b = bake_plane_case(16);
  const formats::Walls& w = *b.walls;
  for (FaceIndex f = 0; f < b.faces.face_count(); ++f) {
    if (w.face_tile[f] == kInvalidIndex || !in_middle(b, f)) continue;
    const Vec3 n0 = b.cage.rest_positions.col(b.faces.nodes(0, f));
    const Vec3 e1 = b.cage.rest_positions.col(b.faces.nodes(1, f)) - n0, e2 = b.cage.rest_positions.col(b.faces.nodes(2, f)) - n0;
    for (std::uint32_t j = 0; j < w.resolution; ++j) {
      for (std::uint32_t i = 0; i < w.resolution; ++i) {
        const double u = (i + 0.5) / w.resolution, v = (j + 0.5) / w.resolution;
        if (u + v > 1.0) continue;
        const Vec3 x = n0 + u * e1 + v * e2;
        if (x.z() == 0.3) continue;
        EXPECT_EQ(w.sdf[(w.face_tile[f] * w.resolution + j) * w.resolution + i] >= 128, x.z() < 0.3)
            << "face " << f << " texel " << i << "," << j;
      }
    }
  }
}

TEST(Walls, SurfacesLyingOnCageFacesStillVerify) {
  // Every face of this box lies in grid planes: contours run along cage edges and
  // triangles lie in cage faces, the degenerate cases of walls and mass.
  const SurfaceMesh box = testing::box_surface(Vec3::Constant(-0.5), Vec3::Constant(0.5), 4);
  const TetMesh cage = testing::grid_cage(Vec3::Constant(-1), Vec3::Constant(1), 4, 4, 4);
  const formats::Bundle b = embed(box, cage, BakeOptions{}, "aligned box", "grid");
  const formats::VerifyReport report = formats::verify_bundle(b);
  for (const auto& check : report.checks) EXPECT_TRUE(check.passed) << check.name << ": " << check.detail;
}

TEST(Walls, BeyondTheDiagonalMirrorsTheFace) {
  const formats::Bundle b = bake_plane_case(16);
  const formats::Walls& w = *b.walls;
  const std::size_t res = w.resolution;
  for (std::size_t tile = 0; tile < w.tile_count(); ++tile) {
    const std::uint8_t* t = &w.sdf[tile * res * res];
    for (std::size_t j = 0; j < res; ++j) {
      for (std::size_t i = 0; i < res; ++i) {
        if (i + j + 1 > res) {
          ASSERT_EQ(t[j * res + i], t[(res - 1 - i) * res + (res - 1 - j)]) << "tile " << tile;
        }
      }
    }
  }
}

TEST(Walls, DetailMapsAreSeededAndTileable) {
  std::vector<std::uint8_t> a, a_normal, b, b_normal, c, c_normal;
  bake_detail(64, 7, a, a_normal);
  bake_detail(64, 7, b, b_normal);
  bake_detail(64, 8, c, c_normal);
  EXPECT_EQ(a, b);
  EXPECT_EQ(a_normal, b_normal);
  EXPECT_NE(a, c);
  // Across the wrap-around seam the height changes no more than between neighbours inside.
  int inner = 0, seam = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x + 1 < 64; ++x) inner = std::max(inner, std::abs(a[y * 64 + x + 1] - a[y * 64 + x]));
    seam = std::max(seam, std::abs(a[y * 64] - a[y * 64 + 63]));
  }
  EXPECT_LE(seam, inner);
  EXPECT_GT(inner, 0);
}

// Inside the slab-topped box the distance to its surface is the least distance to its
// six planes: a minimum of linear functions, so concave, and its least value over a face
// lies at a corner. The clearance must never exceed it (relief displaced that far stays
// inside) and must come within the 10% tolerance of it.
TEST(Walls, InteriorFaceClearanceIsWithinTenPercentBelowTheExactDistance) {
  const formats::Bundle b = bake_plane_case(8);
  const auto box_distance = [](const Vec3& p) {
    return std::min({p.x() + 0.9, 0.9 - p.x(), p.y() + 0.9, 0.9 - p.y(), p.z() + 0.9, 0.3 - p.z()});
  };
  const formats::Walls& w = *b.walls;
  ASSERT_EQ(w.face_clearance.size(), b.faces.face_count());
  std::size_t inside = 0;
  for (FaceIndex f = 0; f < b.faces.face_count(); ++f) {
    if (w.face_class[f] != formats::FaceClass::Inside) {
      EXPECT_EQ(w.face_clearance[f], 0.0) << "face " << f;
      continue;
    }
    ++inside;
    double exact = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) exact = std::min(exact, box_distance(b.cage.rest_positions.col(b.faces.nodes(k, f))));
    EXPECT_LE(w.face_clearance[f], exact * (1.0 + 1e-12)) << "face " << f;
    EXPECT_GE(w.face_clearance[f], 0.9 * exact) << "face " << f;
  }
  EXPECT_GT(inside, 20u);
  EXPECT_TRUE(formats::verify_bundle(b).passed());
}

TEST(Walls, ClearanceSurvivesTheBundleFile) {
  const formats::Bundle baked = bake_plane_case(8);
  const testing::TempDir dir;
  formats::write_bundle(dir / "slab.h5", baked);
  const formats::Bundle read = formats::read_bundle(dir / "slab.h5");
  ASSERT_TRUE(read.walls.has_value());
  EXPECT_EQ(read.walls->face_clearance, baked.walls->face_clearance);
}

TEST(Walls, VerifyRejectsAClearanceOnAFaceThatIsNotInside) {
  formats::Bundle b = bake_plane_case(8);
  formats::Walls& w = *b.walls;
  for (FaceIndex f = 0; f < b.faces.face_count(); ++f) {
    if (w.face_class[f] == formats::FaceClass::Crossing) {
      w.face_clearance[f] = 0.01;
      break;
    }
  }
  EXPECT_FALSE(formats::verify_bundle(b).passed());
}

TEST(Walls, BadOptionsAreErrors) {
  WallOptions options;
  options.resolution = 0;
  EXPECT_THROW(validate(options), Error);
  options.resolution = 64;
  options.sdf_range_texels = -1;
  EXPECT_THROW(validate(options), Error);
  // A budget too small for the tiles.
  const PlaneCase c;
  BakeOptions bake;
  bake.collision = false;
  bake.wall.resolution = 256;
  bake.wall.memory_budget_bytes = 1 << 20;
  EXPECT_THROW(embed(c.mesh, c.cage, bake, "slab", "grid"), Error);
}

}  // namespace
}  // namespace fissure::bake
