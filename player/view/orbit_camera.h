#pragma once
/// The viewer's camera: it orbits a target at a distance (turntable style, the world's up
/// kept up), pans the target across the view and zooms by distance; and the ray from the
/// eye through a pixel, to aim a shot.

#include <Eigen/Core>

#include "player/render/renderer.h"

namespace fissure::view {

using render::Vec3f;

struct Ray {
  Vec3f origin, direction;  ///< direction unit
};

class OrbitCamera {
 public:
  /// Takes over where `camera` looks from (its eye, target, up and fov).
  explicit OrbitCamera(const render::Camera& camera);

  /// Turns the eye about the target: `dx`, `dy` in pixels of mouse motion.
  void orbit(float dx, float dy);
  /// Moves eye and target across the view so the scene follows the mouse: `dx`, `dy`
  /// pixels in a viewport `viewport_height` pixels high.
  void pan(float dx, float dy, int viewport_height);
  /// Scroll steps: positive moves closer (each step 10% of the distance).
  void zoom(float steps);

  [[nodiscard]] render::Camera camera() const;
  /// The ray from the eye through pixel (x, y), counted from the top left, of a
  /// `width` × `height` image.
  [[nodiscard]] Ray ray(float x, float y, int width, int height) const;

 private:
  [[nodiscard]] Vec3f offset() const;  ///< from the target to the eye

  render::Camera m_base;   ///< fov, up, clip planes
  Vec3f m_target;
  float m_distance;
  float m_yaw, m_pitch;    ///< [rad], about up and above the horizon
  Vec3f m_right0, m_forward0;  ///< the horizontal frame yaw is measured in
};

}  // namespace fissure::view
