#include "player/view/orbit_camera.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace fissure::view {

namespace {
constexpr float kRadiansPerPixel = 0.008f;
constexpr float kMaxPitch = 1.5f;  ///< just short of straight up or down, where yaw is undefined
}  // namespace

OrbitCamera::OrbitCamera(const render::Camera& camera) : m_base(camera), m_target(camera.target) {
  const Vec3f up = camera.up.normalized();
  const Vec3f to_eye = camera.eye - camera.target;
  m_distance = std::max(to_eye.norm(), 1e-6f);
  m_forward0 = up.unitOrthogonal();
  m_right0 = up.cross(m_forward0);
  const Vec3f direction = to_eye / m_distance;
  m_pitch = std::asin(std::clamp(direction.dot(up), -1.0f, 1.0f));
  m_yaw = std::atan2(direction.dot(m_right0), direction.dot(m_forward0));
  m_base.up = up;
}

Vec3f OrbitCamera::offset() const {
  const Vec3f horizontal = std::cos(m_yaw) * m_forward0 + std::sin(m_yaw) * m_right0;
  return m_distance * (std::cos(m_pitch) * horizontal + std::sin(m_pitch) * m_base.up);
}

void OrbitCamera::orbit(float dx, float dy) {
  m_yaw -= kRadiansPerPixel * dx;
  m_pitch = std::clamp(m_pitch + kRadiansPerPixel * dy, -kMaxPitch, kMaxPitch);
}

void OrbitCamera::pan(float dx, float dy, int viewport_height) {
  const render::Camera c = camera();
  const Vec3f forward = (c.target - c.eye).normalized();
  const Vec3f right = forward.cross(c.up).normalized(), up = right.cross(forward);
  // A pixel spans this many metres at the target's depth.
  const float metres_per_pixel = 2.0f * m_distance *
                                 std::tan(0.5f * m_base.fov_y_degrees * std::numbers::pi_v<float> / 180.0f) /
                                 static_cast<float>(std::max(viewport_height, 1));
  m_target += metres_per_pixel * (-dx * right + dy * up);
}

void OrbitCamera::zoom(float steps) { m_distance = std::max(m_distance * std::pow(0.9f, steps), 1e-4f); }

render::Camera OrbitCamera::camera() const {
  render::Camera c = m_base;
  c.target = m_target;
  c.eye = m_target + offset();
  // Clip planes scale with the distance, so zooming never cuts the scene.
  const float scale = m_distance / std::max((m_base.eye - m_base.target).norm(), 1e-6f);
  c.near_plane = m_base.near_plane * scale;
  c.far_plane = m_base.far_plane * scale;
  return c;
}

Ray OrbitCamera::ray(float x, float y, int width, int height) const {
  const render::Camera c = camera();
  const Vec3f forward = (c.target - c.eye).normalized();
  const Vec3f right = forward.cross(c.up).normalized(), up = right.cross(forward);
  const float tan_half = std::tan(0.5f * c.fov_y_degrees * std::numbers::pi_v<float> / 180.0f);
  const float aspect = static_cast<float>(width) / static_cast<float>(std::max(height, 1));
  // Pixel centres, in [-1, 1] across the image.
  const float u = 2.0f * (x + 0.5f) / static_cast<float>(width) - 1.0f;
  const float v = 1.0f - 2.0f * (y + 0.5f) / static_cast<float>(height);
  const Vec3f direction = (forward + u * tan_half * aspect * right + v * tan_half * up).normalized();
  return {c.eye, direction};
}

}  // namespace fissure::view
