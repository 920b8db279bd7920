#pragma once
/// Generalized winding numbers (Jacobson et al. 2013) of query points with respect to
/// a triangle soup, evaluated hierarchically (Barill et al. 2018, "Fast winding
/// numbers for soups and clouds"): exact solid angles near the query, a Taylor
/// expansion to second order for far clusters. For a closed outward-oriented surface the result is
/// 1 inside and 0 outside; for open or self-intersecting art it degrades gracefully
/// (about 0.5 across a hole), which is why the bake classifies with w ≥ 0.5 rather
/// than by ray parity, which fails on the open scan.
///
/// Cost: O(M) to build for M triangles, about O(log M) per query, instead of the
/// O(M) per query of the direct sum — the bake must not grow like nodes × triangles.

#include <vector>

#include "common/surface_mesh.h"

namespace fissure::bake {

class WindingNumberTree {
 public:
  /// `accuracy` is Barill's β: a cluster is approximated when the query is farther
  /// than β times its radius. Measured on the sample bunny (worst absolute error over
  /// 2,000 points in its bounding box): β = 2: 3e-2, 3: 1.2e-2, 4: 6e-3, 6: 1e-3. The bake
  /// only compares with 0.5, and values near 0.5 occur only within a hair of the
  /// surface, so 3 is plenty there.
  explicit WindingNumberTree(const SurfaceMesh& mesh, double accuracy = 3.0);

  [[nodiscard]] double winding_number(const Vec3& query) const;

  /// The exact sum over all triangles, for tests and small inputs.
  [[nodiscard]] double winding_number_direct(const Vec3& query) const;

 private:
  struct Node {
    Vec3 box_min, box_max;
    Vec3 center;        ///< area-weighted centroid of the cluster
    Vec3 area_normal;   ///< Σ aₜ nₜ (the dipole moment)
    Mat3 second_moment; ///< Σ aₜ (cₜ − center) nₜᵀ (the second-order term)
    double area = 0;    ///< Σ aₜ
    double radius = 0;  ///< distance from `center` to the farthest corner of the box
    Index first = 0, count = 0;  ///< range in m_order (leaves)
    Index left = kInvalidIndex, right = kInvalidIndex;
  };

  /// Builds the subtree over m_order[first, first + count); moments of inner nodes
  /// are combined from their children's, so the build is O(M log M) in the splits only.
  Index build(Index first, Index count, const std::vector<Vec3>& centroids, const std::vector<Vec3>& area_vectors);
  [[nodiscard]] double solid_angle(Index triangle, const Vec3& query) const;

  const SurfaceMesh& m_mesh;
  double m_accuracy;
  std::vector<Node> m_nodes;
  std::vector<Index> m_order;  ///< triangles, permuted so each node's are contiguous
};

}  // namespace fissure::bake
