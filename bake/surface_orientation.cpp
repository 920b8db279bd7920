#include "bake/surface_orientation.h"

#include <algorithm>
#include <array>
#include <deque>
#include <utility>
#include <vector>

#include "bake/winding_number.h"

namespace fissure::bake {
namespace {

struct EdgeUse {
  Index low, high;   ///< position representatives, low < high
  Index triangle;
  bool forward;      ///< the triangle runs low → high
};

struct Neighbour {
  Index triangle;
  bool same_direction;  ///< both cross the shared edge the same way: one of them is flipped
};

struct Pieces {
  std::vector<Index> piece;          ///< per triangle; kInvalidIndex for degenerate ones
  std::vector<std::uint8_t> parity;  ///< per triangle: 1 = flip to agree with the piece's seed
  std::vector<std::uint8_t> conflicting, closed;  ///< per piece
  std::size_t count = 0;
};

std::vector<std::vector<Neighbour>> manifold_neighbours(const SurfaceMesh& mesh, const std::vector<Index>& rep,
                                                        std::vector<std::uint8_t>& on_open_edge) {
  std::vector<EdgeUse> uses;
  uses.reserve(mesh.triangle_count() * 3);
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    if (bounds_nothing(mesh, rep, t)) continue;
    const std::array<Index, 3> v = {rep[mesh.triangles(0, t)], rep[mesh.triangles(1, t)], rep[mesh.triangles(2, t)]};
    for (int k = 0; k < 3; ++k) {
      const Index a = v[k], b = v[(k + 1) % 3];
      uses.push_back({std::min(a, b), std::max(a, b), t, a < b});
    }
  }
  std::sort(uses.begin(), uses.end(),
            [](const EdgeUse& x, const EdgeUse& y) { return std::tie(x.low, x.high, x.triangle) < std::tie(y.low, y.high, y.triangle); });
  std::vector<std::vector<Neighbour>> neighbours(mesh.triangle_count());
  on_open_edge.assign(mesh.triangle_count(), 0);
  for (std::size_t i = 0; i < uses.size();) {
    std::size_t j = i;
    while (j < uses.size() && uses[j].low == uses[i].low && uses[j].high == uses[i].high) ++j;
    if (j - i == 2) {
      const bool same = uses[i].forward == uses[i + 1].forward;
      neighbours[uses[i].triangle].push_back({uses[i + 1].triangle, same});
      neighbours[uses[i + 1].triangle].push_back({uses[i].triangle, same});
    } else {
      for (std::size_t k = i; k < j; ++k) on_open_edge[uses[k].triangle] = 1;
    }
    i = j;
  }
  return neighbours;
}

Pieces find_pieces(const SurfaceMesh& mesh) {
  const std::vector<Index> rep = position_representatives(mesh.positions);
  std::vector<std::uint8_t> on_open_edge;
  const auto neighbours = manifold_neighbours(mesh, rep, on_open_edge);
  Pieces p;
  p.piece.assign(mesh.triangle_count(), kInvalidIndex);
  p.parity.assign(mesh.triangle_count(), 0);
  for (Index seed = 0; seed < mesh.triangle_count(); ++seed) {
    if (p.piece[seed] != kInvalidIndex || bounds_nothing(mesh, rep, seed)) continue;
    const Index id = p.count++;
    p.conflicting.push_back(0);
    p.closed.push_back(1);
    std::deque<Index> queue{seed};
    p.piece[seed] = id;
    while (!queue.empty()) {
      const Index t = queue.front();
      queue.pop_front();
      if (on_open_edge[t]) p.closed[id] = 0;
      for (const Neighbour& n : neighbours[t]) {
        const std::uint8_t want = p.parity[t] ^ static_cast<std::uint8_t>(n.same_direction);
        if (p.piece[n.triangle] == kInvalidIndex) {
          p.piece[n.triangle] = id;
          p.parity[n.triangle] = want;
          queue.push_back(n.triangle);
        } else if (p.parity[n.triangle] != want) {
          p.conflicting[id] = 1;  // a Möbius-like piece: no assignment agrees everywhere
        }
      }
    }
  }
  return p;
}

void flip(SurfaceMesh& mesh, Index t) {
  std::swap(mesh.triangles(1, static_cast<Eigen::Index>(t)), mesh.triangles(2, static_cast<Eigen::Index>(t)));
}

/// Signed volume of each piece (about the first vertex, for less cancellation), and
/// its vertex of largest x.
void piece_volumes(const SurfaceMesh& mesh, const Pieces& p, std::vector<double>& volume, std::vector<Vec3>& extreme) {
  volume.assign(p.count, 0.0);
  extreme.assign(p.count, Vec3::Constant(-std::numeric_limits<double>::infinity()));
  const Vec3 origin = mesh.positions.col(0);
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    const Index id = p.piece[t];
    if (id == kInvalidIndex) continue;
    std::array<Vec3, 3> x;
    for (int k = 0; k < 3; ++k) {
      x[k] = mesh.positions.col(static_cast<Eigen::Index>(mesh.triangles(k, static_cast<Eigen::Index>(t))));
      if (x[k].x() > extreme[id].x()) extreme[id] = x[k];
    }
    volume[id] += (x[0] - origin).dot((x[1] - origin).cross(x[2] - origin)) / 6.0;
  }
}

/// Closed pieces that enclose negative volume outside every other piece.
std::vector<std::uint8_t> inside_out_pieces(const SurfaceMesh& mesh, const Pieces& p) {
  std::vector<double> volume;
  std::vector<Vec3> extreme;
  piece_volumes(mesh, p, volume, extreme);
  std::vector<std::uint8_t> inside_out(p.count, 0);
  const bool any_negative = std::any_of(volume.begin(), volume.end(), [](double v) { return v < 0.0; });
  if (!any_negative) return inside_out;
  const WindingNumberTree winding(mesh);
  const Vec3 lo = mesh.positions.rowwise().minCoeff(), hi = mesh.positions.rowwise().maxCoeff();
  // Just beyond the piece's rightmost vertex: outside the piece itself (its own
  // winding number there is 0), inside whatever encloses it.
  const double step = 1e-6 * (hi - lo).norm();
  for (Index id = 0; id < p.count; ++id) {
    if (!p.closed[id] || p.conflicting[id] || volume[id] >= 0.0) continue;
    inside_out[id] = winding.winding_number(extreme[id] + Vec3(step, 0, 0)) < 0.5 ? 1 : 0;
  }
  return inside_out;
}

}  // namespace

OrientationRepair orient_surface(SurfaceMesh& mesh) {
  OrientationRepair r;
  if (mesh.triangle_count() == 0) return r;
  const Pieces p = find_pieces(mesh);
  r.components = p.count;
  std::vector<std::array<double, 2>> area(p.count, {0.0, 0.0});
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    if (p.piece[t] != kInvalidIndex) area[p.piece[t]][p.parity[t]] += triangle_area(mesh, t);
  }
  for (Index id = 0; id < p.count; ++id) r.non_orientable += p.conflicting[id];
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    const Index id = p.piece[t];
    if (id == kInvalidIndex || p.conflicting[id]) continue;
    const std::uint8_t minority = area[id][1] <= area[id][0] ? 1 : 0;
    if (p.parity[t] == minority) {
      flip(mesh, t);
      ++r.flipped_to_agree;
    }
  }
  const std::vector<std::uint8_t> inside_out = inside_out_pieces(mesh, p);
  for (Index id = 0; id < p.count; ++id) r.inside_out_pieces += inside_out[id];
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    if (p.piece[t] != kInvalidIndex && inside_out[p.piece[t]]) {
      flip(mesh, t);
      ++r.flipped_inside_out;
    }
  }
  return r;
}

}  // namespace fissure::bake
