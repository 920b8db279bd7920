#include "player/app/render_frame.h"

#include <algorithm>

namespace fissure::player {

namespace {

void to_float(const Matrix3Xd& from, std::vector<float>& to) {
  to.resize(static_cast<std::size_t>(from.size()));
  std::transform(from.data(), from.data() + from.size(), to.begin(), [](double x) { return static_cast<float>(x); });
}

}  // namespace

void update_render_frame(const sim::BodyFrame& frame, RenderFrame& out) {
  to_float(frame.positions, out.positions);
  to_float(frame.previous_positions, out.previous_positions);
  out.deformation.resize(9 * frame.deformation.size());
  for (std::size_t t = 0; t < frame.deformation.size(); ++t) {
    const Mat3& F = frame.deformation[t];
    std::transform(F.data(), F.data() + 9, out.deformation.begin() + static_cast<std::ptrdiff_t>(9 * t),
                   [](double x) { return static_cast<float>(x); });
  }
  out.topology_changed = frame.topology_version != out.topology_version;
  if (!out.topology_changed) return;
  out.tets.assign(frame.tets.data(), frame.tets.data() + frame.tets.size());
  out.faces.resize(frame.faces.size());
  std::transform(frame.faces.begin(), frame.faces.end(), out.faces.begin(),
                 [](sim::FaceState f) { return static_cast<std::uint8_t>(f); });
  out.fragment.assign(frame.fragment.begin(), frame.fragment.end());
  out.topology_version = frame.topology_version;
}

}  // namespace fissure::player
