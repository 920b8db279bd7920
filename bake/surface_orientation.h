#pragma once
/// Repairs triangle orientation before the embedding (issue 17). Inside/outside comes
/// from generalized winding numbers, which count a flipped triangle against its
/// neighbours and an inside-out shell as negative space: the bake would drop that
/// solid from the physics and the collision-mass check would fail.
///
/// Deviation from the thesis, which assumes well-formed input: the bake orients the
/// surface itself, and says so, rather than rejecting art that every DCC tool draws
/// correctly (back-face culling off) and that is common in scanned or converted assets.

#include <cstddef>

#include "common/surface_mesh.h"

namespace fissure::bake {

struct OrientationRepair {
  std::size_t components = 0;          ///< pieces connected through manifold edges
  std::size_t flipped_to_agree = 0;    ///< triangles flipped to agree with their piece
  std::size_t inside_out_pieces = 0;   ///< closed pieces turned right side out
  std::size_t flipped_inside_out = 0;  ///< triangles in those pieces
  std::size_t non_orientable = 0;      ///< pieces no flips make consistent (left as they are)
  [[nodiscard]] std::size_t flipped() const { return flipped_to_agree + flipped_inside_out; }
};

/// 1. In each piece (triangles connected through edges used exactly twice), makes
///    every triangle cross each shared edge opposite to its neighbour, flipping the
///    side of smaller total area: one stray triangle is flipped, never the piece.
/// 2. A closed piece that encloses negative volume and does not lie inside another
///    piece (the winding number of the rest just outside it is below ½) is inside
///    out: all its triangles are flipped. A negative piece inside another is a cavity
///    and stays as it is.
/// Vertices at bit-identical positions count as one. Degenerate triangles are skipped.
OrientationRepair orient_surface(SurfaceMesh& mesh);

}  // namespace fissure::bake
