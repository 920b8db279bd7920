#pragma once
/// Procedural meshes and cages shared by tests and benchmarks, so both measure the
/// same inputs. Everything here is deterministic.

#include <filesystem>

#include "common/surface_mesh.h"
#include "common/tet_mesh.h"

namespace fissure::testing {

/// Icosphere: an icosahedron subdivided `levels` times, vertices on the sphere.
/// Closed, outward oriented.
SurfaceMesh icosphere(int levels, double radius = 1.0, const Vec3& center = Vec3::Zero());

/// Torus around the z axis, `major` and `minor` radii, u×v quads split in two.
SurfaceMesh torus(double major, double minor, int u_segments, int v_segments);

/// Axis-aligned box surface from `lo` to `hi`, each face an n×n grid of quad pairs.
SurfaceMesh box_surface(const Vec3& lo, const Vec3& hi, int n);

/// The thesis's early procedural cage: a regular grid of nx×ny×nz cubes over
/// [lo, hi], each cube split into 6 tets around its main diagonal (Kuhn split, so
/// neighbouring cubes' faces match).
TetMesh grid_cage(const Vec3& lo, const Vec3& hi, int nx, int ny, int nz);

/// Midpoint subdivision: every triangle into 4 (vertices shared along edges).
SurfaceMesh subdivide(const SurfaceMesh& mesh);

/// Writes positions and triangles as a plain OBJ.
void write_obj(const SurfaceMesh& mesh, const std::filesystem::path& path);

/// Directory of the repository's sample data (data/), set by CMake.
std::filesystem::path data_dir();

}  // namespace fissure::testing
