#pragma once
/// The camera's matrices (OpenGL conventions: right-handed view, clip z in [-w, w]).

#include "player/render/renderer.h"

namespace fissure::render {

/// World to view: the eye at the origin looking down −z, `up` towards +y.
Mat4f look_at(const Camera& c);
/// View to clip for the camera's vertical field of view and planes.
Mat4f perspective(const Camera& c, float aspect);

}  // namespace fissure::render
