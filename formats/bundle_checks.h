#pragma once
/// The invariants a bundle must satisfy, checked from its data alone (no CGAL), so
/// `fissure-bake verify` and CI can trust a bundle without re-baking it.

#include <cstddef>
#include <string>
#include <vector>

#include "formats/bundle.h"

namespace fissure::formats {

struct VerifyTolerances {
  double barycentric_sum = 1e-12;  ///< |Σβ − 1| / max(1, Σ|β|) per vertex and instance
  double reconstruction = 1e-9;    ///< |Σβp − v| relative to the cage's bounding-box diagonal
  double coverage = 1e-9;          ///< |Σ clipped area − area| relative to the triangle's area
  double contour = 1e-9;           ///< contour end point off its face or triangle, relative to the diagonal
};

struct VerifyCheck {
  std::string name;    ///< e.g. "barycentric-sums"
  bool passed = true;
  std::string detail;  ///< what was measured, or the first failure
};

struct VerifyReport {
  std::vector<VerifyCheck> checks;
  [[nodiscard]] bool passed() const;
};

VerifyReport verify_bundle(const Bundle& bundle, const VerifyTolerances& tolerances = {});

/// For each render triangle, the area [m²] of its parts inside the tets it is
/// assigned to (Σ over its instances of area(triangle ∩ tet)).
std::vector<double> covered_area(const SurfaceMesh& render, const TetMesh& cage, const Embedding& embedding);

/// Texel centres of a face's tile inside the face (u + v ≤ 1) whose SDF byte says
/// inside, times the texel area: the tile's estimate of the face's inside area [m²].
/// Faces without a tile: the face area if classed inside, else 0.
double tile_inside_area(const Walls& walls, FaceIndex face, double area);

/// Volume enclosed by a closed, outward-oriented surface (divergence theorem) [m³].
double enclosed_volume(const SurfaceMesh& mesh);

/// Number of render triangles stored k times, for k = 1 … 7 and 8+ (index 0 counts
/// triangles with no instance at all). Thesis Table II.
std::vector<std::size_t> replication_histogram(std::size_t triangle_count, const Embedding& embedding);

}  // namespace fissure::formats
