#pragma once
/// The wrap cage (issue 43, `--method wrap`): a shape-following cage. CGAL's
/// alpha_wrap_3 makes a watertight, manifold envelope of the surface (robust to open,
/// holed and self-intersecting input) at a distance `offset` outside it; make_mesh_3
/// fills the envelope with tets of about `cell`, and perturb/exude remove slivers.
/// wrap_cage.cpp is the one translation unit that includes Mesh_3 (it takes minutes and
/// gigabytes to compile); this header is CGAL-free.

#include <cstddef>

#include "common/surface_mesh.h"
#include "common/tet_mesh.h"

namespace fissure::bake {

struct WrapParameters {
  double alpha = 0;   ///< the wrap's ball size [m]: gaps narrower than it close
  double offset = 0;  ///< the envelope's distance outside the surface [m]
};

/// The envelope of one WrapParameters, meshed at any cell size.
class SurfaceWrap {
 public:
  SurfaceWrap(const SurfaceMesh& mesh, const WrapParameters& parameters);
  ~SurfaceWrap();
  SurfaceWrap(const SurfaceWrap&) = delete;
  SurfaceWrap& operator=(const SurfaceWrap&) = delete;

  /// The envelope's tet mesh at cells of about `cell` [m], its boundary within
  /// `facet_distance` [m] of the envelope (below the offset, or the cage may cut into
  /// the surface; the smaller, the more tets along the boundary); with `polish`,
  /// perturbed and exuded (sliver bound 10°). Deterministic: every run seeds its own
  /// generator. The envelope is made once, so a search over cells re-meshes only.
  [[nodiscard]] TetMesh mesh_at(double cell, double facet_distance, bool polish) const;
  [[nodiscard]] std::size_t envelope_triangles() const;

 private:
  struct Impl;
  Impl* m_impl;
};

}  // namespace fissure::bake
