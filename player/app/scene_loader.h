#pragma once
/// Builds a running world from a scene file and the bundles it names: places each
/// cage in the world, binds collision spheres and render vertices, applies pins,
/// initial velocities and materials. The player's only contact with bundle files.

#include <string>
#include <vector>

#include "formats/scene.h"
#include "player/sim/world.h"

namespace fissure::player {

struct LoadedScene {
  sim::World world;
  std::vector<std::string> bundle_names;  ///< per body, the bundle's file name
};

/// Throws fissure::Error naming the scene file, line and object for anything a bundle
/// makes invalid (missing file, pinned node out of range).
LoadedScene load_scene(const formats::Scene& scene);

}  // namespace fissure::player
