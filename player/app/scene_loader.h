#pragma once
/// Builds a running world from a scene file and the bundles it names: places each
/// cage in the world, binds collision spheres and render vertices, applies pins,
/// initial velocities and materials. The player's only contact with bundle files.

#include <string>
#include <vector>

#include "formats/bundle.h"
#include "formats/scene.h"
#include "player/sim/world.h"

namespace fissure::player {

/// What the player keeps of one body's bundle, read once at load, for rendering: the
/// render mesh and its instances (barycentric in the cage's tets, so they follow the
/// simulated nodes whatever the object's placement), the face table, wall tiles and
/// collision spheres. The cage itself lives on in the world.
struct BodyAssets {
  std::string bundle_name;  ///< the bundle's file name
  formats::Bundle bundle;
  double scale = 1;         ///< the scene's uniform scale of the object (walls' depths, sphere radii)
  std::optional<Vec3> color, interior_color;  ///< the scene's colours; none: the renderer's defaults
};

struct LoadedScene {
  sim::World world;
  std::vector<BodyAssets> assets;  ///< per body, in the world's body order
  std::optional<formats::SceneCamera> camera;  ///< the scene's [camera]; none: frame the bodies
};

/// Throws fissure::Error naming the scene file, line and object for anything a bundle
/// makes invalid (missing file, pinned node out of range).
LoadedScene load_scene(const formats::Scene& scene);

}  // namespace fissure::player
