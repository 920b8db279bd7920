#pragma once
/// Plain meshes the player and its debug views draw: spheres for balls, projectiles
/// and collision spheres.

#include "player/render/renderer.h"

namespace fissure::render {

/// A unit sphere about the origin, `rings` × `segments` quads split in two (the poles'
/// quads degenerate); normals are the positions.
PlainMesh unit_sphere(int rings, int segments);

/// The sphere the collision-sphere view instances: coarse, as a scene may hold
/// thousands, fine enough to read as round at the sizes spheres are seen.
inline constexpr int kDebugSphereRings = 10, kDebugSphereSegments = 20;

}  // namespace fissure::render
