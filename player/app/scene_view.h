#pragma once
/// What the player draws of a world: each body's embedded render mesh (from its
/// bundle), the ground, the static boxes and balls, and the projectiles; a camera that
/// frames the bodies and follows them (a hit can send a body metres away). update()
/// poses everything from the world's current state.

#include <cstddef>
#include <optional>
#include <vector>

#include "player/app/render_frame.h"
#include "player/app/scene_loader.h"
#include "player/render/renderer.h"

namespace fissure::player {

/// Body `body`'s instances as the renderer takes them, with smooth rest normals
/// computed from the render mesh placed by the world's rest cage (so in world axes,
/// whatever the object's rotation and scale). `scale`: the scene's uniform scale of the
/// object (the walls' relief is in world metres).
render::EmbeddedMesh embedded_mesh(const formats::Bundle& bundle, const sim::ImplicitIntegrator& body, double scale);

/// The physics' collision spheres of a body, for the renderer's sphere view.
void add_collision_spheres(const sim::EmbeddedPoints& spheres, render::EmbeddedMesh& mesh);

class SceneView {
 public:
  /// Adds the world's bodies and obstacles to `renderer` and frames the camera, or
  /// places it where `camera` says (then it stays there).
  SceneView(const sim::World& world, const std::vector<BodyAssets>& assets, render::Renderer& renderer,
            const std::optional<formats::SceneCamera>& camera = {});

  /// Poses every body and projectile as the world is now (the renderer counts the bytes
  /// this uploads: positions, and tets only when fracture changed them), and widens the
  /// camera's near and far planes to hold them.
  void update(const sim::World& world);

  /// The camera the last update() placed.
  [[nodiscard]] const render::Camera& camera() const { return m_current; }
  /// Places the camera where a user put it; it stays there (no longer follows the bodies).
  void set_camera(const render::Camera& camera);
  /// Back to the camera the view started with (framed and following, or the scene's).
  void restore_camera();

 private:
  /// Widens `camera`'s near and far planes to hold what the world has now.
  void fit_planes(const sim::World& world, render::Camera& camera) const;

  render::Renderer& m_renderer;
  std::vector<std::size_t> m_bodies;       ///< renderer handle per body
  std::vector<RenderFrame> m_frames;       ///< per body
  std::vector<std::size_t> m_projectiles;  ///< renderer handle per projectile
  render::PlainMesh m_projectile_mesh;     ///< for projectiles added while the world runs (a viewer's shots)
  render::Camera m_camera;                 ///< as framed at the start; update() moves it with the bodies
  bool m_follow = true;                    ///< false: the scene placed the camera
  Vec3 m_start_centre;                     ///< the bodies' centre at the start
  render::Camera m_current;                ///< as the last update() placed it
  render::Camera m_start_camera;           ///< m_camera as the constructor made it
  bool m_start_follow = true;              ///< m_follow likewise
};

}  // namespace fissure::player
