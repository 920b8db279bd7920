#pragma once
/// A body's frame as the renderer takes it: plain float and integer arrays
/// (docs/architecture.md, "The sim/render boundary": `render` takes spans; the app
/// converts, so `sim` and `render` never include each other). Positions change every
/// step (and deformation gradients, for a caller that asks: the renderer computes its
/// own from the positions); the tet table and the per-tet face and fragment arrays only
/// when the topology version does, so a renderer re-uploads them only then.

#include <cstdint>
#include <limits>
#include <vector>

#include "player/sim/world.h"

namespace fissure::player {

struct RenderFrame {
  std::vector<float> positions;           ///< 3 per node [m]
  std::vector<float> previous_positions;  ///< 3 per node, at the start of the last step
  std::vector<float> deformation;         ///< 9 per tet: F, column-major (empty when the frame had none)
  std::vector<std::uint32_t> tets;        ///< 4 per tet (node indices)
  std::vector<std::uint8_t> faces;        ///< 4 per tet: sim::FaceState of face k (opposite corner k)
  std::vector<std::uint32_t> fragment;    ///< per tet
  std::uint64_t topology_version = std::numeric_limits<std::uint64_t>::max();  ///< what `tets` is of
  bool topology_changed = false;          ///< the last update rewrote tets, faces and fragment
};

/// Brings `out` up to `frame`; rewrites the connectivity arrays only when the version
/// differs from the one `out` holds.
void update_render_frame(const sim::BodyFrame& frame, RenderFrame& out);

}  // namespace fissure::player
