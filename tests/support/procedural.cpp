#include "tests/support/procedural.h"

#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <vector>

namespace fissure::testing {
namespace {

SurfaceMesh from_lists(const std::vector<Vec3>& points, const std::vector<std::array<Index, 3>>& triangles) {
  SurfaceMesh mesh;
  mesh.positions.resize(3, static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) mesh.positions.col(static_cast<Eigen::Index>(i)) = points[i];
  mesh.triangles.resize(3, static_cast<Eigen::Index>(triangles.size()));
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) mesh.triangles(k, static_cast<Eigen::Index>(t)) = triangles[t][static_cast<std::size_t>(k)];
  }
  return mesh;
}

}  // namespace

SurfaceMesh subdivide(const SurfaceMesh& mesh) {
  std::vector<Vec3> points;
  for (Eigen::Index i = 0; i < mesh.positions.cols(); ++i) points.push_back(mesh.positions.col(i));
  std::map<std::pair<Index, Index>, Index> midpoints;
  auto midpoint = [&](Index a, Index b) {
    const auto key = std::minmax(a, b);
    const auto [it, inserted] = midpoints.emplace(key, static_cast<Index>(points.size()));
    if (inserted) points.push_back(0.5 * (points[a] + points[b]));
    return it->second;
  };
  std::vector<std::array<Index, 3>> triangles;
  for (Eigen::Index t = 0; t < mesh.triangles.cols(); ++t) {
    const Index a = mesh.triangles(0, t), b = mesh.triangles(1, t), c = mesh.triangles(2, t);
    const Index ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    triangles.push_back({a, ab, ca});
    triangles.push_back({ab, b, bc});
    triangles.push_back({ca, bc, c});
    triangles.push_back({ab, bc, ca});
  }
  return from_lists(points, triangles);
}

SurfaceMesh icosphere(int levels, double radius, const Vec3& center) {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> points{{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                           {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
  const std::vector<std::array<Index, 3>> faces{{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                                {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                                {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                                {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  SurfaceMesh mesh = from_lists(points, faces);
  for (int l = 0; l < levels; ++l) mesh = subdivide(mesh);
  for (Eigen::Index i = 0; i < mesh.positions.cols(); ++i) {
    mesh.positions.col(i) = center + radius * mesh.positions.col(i).normalized();
  }
  return mesh;
}

SurfaceMesh torus(double major, double minor, int u_segments, int v_segments) {
  std::vector<Vec3> points;
  std::vector<std::array<Index, 3>> triangles;
  for (int i = 0; i < u_segments; ++i) {
    const double u = 2.0 * std::numbers::pi * i / u_segments;
    for (int j = 0; j < v_segments; ++j) {
      const double v = 2.0 * std::numbers::pi * j / v_segments;
      points.emplace_back((major + minor * std::cos(v)) * std::cos(u), (major + minor * std::cos(v)) * std::sin(u),
                          minor * std::sin(v));
    }
  }
  auto id = [&](int i, int j) {
    return static_cast<Index>(((i + u_segments) % u_segments) * v_segments + (j + v_segments) % v_segments);
  };
  for (int i = 0; i < u_segments; ++i) {
    for (int j = 0; j < v_segments; ++j) {
      triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  }
  return from_lists(points, triangles);
}

SurfaceMesh box_surface(const Vec3& lo, const Vec3& hi, int n) {
  std::vector<Vec3> points;
  std::vector<std::array<Index, 3>> triangles;
  // Each face: fixed axis, sign; (u, v) axes chosen so u × v points outward.
  for (int axis = 0; axis < 3; ++axis) {
    for (int sign = 0; sign < 2; ++sign) {
      int u_axis = (axis + 1) % 3, v_axis = (axis + 2) % 3;
      if (sign == 0) std::swap(u_axis, v_axis);
      const auto base = static_cast<Index>(points.size());
      for (int i = 0; i <= n; ++i) {
        for (int j = 0; j <= n; ++j) {
          Vec3 p;
          p[axis] = sign ? hi[axis] : lo[axis];
          // Ends exactly at lo and hi, so neighbouring faces share their edge vertices.
          auto along = [&](int axis_index, int step) {
            return step == 0 ? lo[axis_index] : step == n ? hi[axis_index] : lo[axis_index] + (hi[axis_index] - lo[axis_index]) * step / n;
          };
          p[u_axis] = along(u_axis, i);
          p[v_axis] = along(v_axis, j);
          points.push_back(p);
        }
      }
      auto id = [&](int i, int j) { return base + static_cast<Index>(i * (n + 1) + j); };
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
          triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
        }
      }
    }
  }
  // Faces share edge vertices by position only; weld them so the surface is closed.
  SurfaceMesh mesh = from_lists(points, triangles);
  const std::vector<Index> representative = position_representatives(mesh.positions);
  for (Eigen::Index i = 0; i < mesh.triangles.size(); ++i) mesh.triangles.data()[i] = representative[mesh.triangles.data()[i]];
  return mesh;
}

TetMesh grid_cage(const Vec3& lo, const Vec3& hi, int nx, int ny, int nz) {
  TetMesh cage;
  const int n[3] = {nx, ny, nz};
  cage.rest_positions.resize(3, (nx + 1) * (ny + 1) * (nz + 1));
  auto id = [&](int i, int j, int k) { return static_cast<Index>((k * (ny + 1) + j) * (nx + 1) + i); };
  for (int k = 0; k <= nz; ++k) {
    for (int j = 0; j <= ny; ++j) {
      for (int i = 0; i <= nx; ++i) {
        const int ijk[3] = {i, j, k};
        for (int a = 0; a < 3; ++a) cage.rest_positions(a, id(i, j, k)) = lo[a] + (hi[a] - lo[a]) * ijk[a] / n[a];
      }
    }
  }
  // Kuhn split: the 6 monotone paths from corner (0,0,0) to (1,1,1).
  static constexpr int kPaths[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  std::vector<Index> tets;
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        for (const auto& path : kPaths) {
          int c[3] = {i, j, k};
          tets.push_back(id(c[0], c[1], c[2]));
          for (int step = 0; step < 3; ++step) {
            ++c[path[step]];
            tets.push_back(id(c[0], c[1], c[2]));
          }
        }
      }
    }
  }
  cage.tets.resize(4, static_cast<Eigen::Index>(tets.size() / 4));
  std::copy(tets.begin(), tets.end(), cage.tets.data());
  for (Eigen::Index t = 0; t < cage.tets.cols(); ++t) {
    if (signed_volume(cage, static_cast<TetIndex>(t)) < 0.0) std::swap(cage.tets(2, t), cage.tets(3, t));
  }
  return cage;
}

void write_obj(const SurfaceMesh& mesh, const std::filesystem::path& path) {
  std::ofstream out(path);
  out.precision(17);
  for (Eigen::Index i = 0; i < mesh.positions.cols(); ++i) {
    out << "v " << mesh.positions(0, i) << ' ' << mesh.positions(1, i) << ' ' << mesh.positions(2, i) << '\n';
  }
  for (Eigen::Index t = 0; t < mesh.triangles.cols(); ++t) {
    out << "f " << mesh.triangles(0, t) + 1 << ' ' << mesh.triangles(1, t) + 1 << ' ' << mesh.triangles(2, t) + 1 << '\n';
  }
}

std::filesystem::path data_dir() { return FISSURE_TEST_DATA_DIR; }

}  // namespace fissure::testing
