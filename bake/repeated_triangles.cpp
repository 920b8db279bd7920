#include "bake/repeated_triangles.h"

#include <algorithm>
#include <array>
#include <numeric>
#include <vector>

namespace fissure::bake {

std::size_t remove_repeated_triangles(SurfaceMesh& mesh) {
  const auto n = static_cast<std::size_t>(mesh.triangle_count());
  if (n < 2) return 0;
  const std::vector<Index> rep = position_representatives(mesh.positions);
  // Corners by position, rotated to start at the smallest: the same key for the same
  // triangle in the same orientation, whichever corner a file lists first.
  std::vector<std::array<Index, 3>> keys(n);
  for (std::size_t t = 0; t < n; ++t) {
    std::array<Index, 3> k{};
    for (int c = 0; c < 3; ++c) k[c] = rep[mesh.triangles(c, static_cast<Eigen::Index>(t))];
    std::rotate(k.begin(), std::min_element(k.begin(), k.end()), k.end());
    keys[t] = k;
  }
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return keys[a] < keys[b]; });
  std::vector<std::uint8_t> repeated(n, 0);
  for (std::size_t i = 1; i < n; ++i) repeated[order[i]] = keys[order[i]] == keys[order[i - 1]];
  const std::size_t removed = static_cast<std::size_t>(std::count(repeated.begin(), repeated.end(), 1));
  if (removed == 0) return 0;
  Eigen::Index kept = 0;
  for (std::size_t t = 0; t < n; ++t) {
    if (!repeated[t]) mesh.triangles.col(kept++) = mesh.triangles.col(static_cast<Eigen::Index>(t));
  }
  mesh.triangles.conservativeResize(3, kept);
  return removed;
}

}  // namespace fissure::bake
