#include <algorithm>
#include <cmath>
#include <numbers>

#include "player/render/camera_math.h"

namespace fissure::render {

Mat4f look_at(const Camera& c) {
  const Vec3f f = (c.target - c.eye).normalized();
  const Vec3f s = f.cross(c.up).normalized();
  const Vec3f u = s.cross(f);
  Mat4f m = Mat4f::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(c.eye);
  m(1, 3) = -u.dot(c.eye);
  m(2, 3) = f.dot(c.eye);
  return m;
}

Mat4f perspective(const Camera& c, float aspect) {
  const float t = 1.0f / std::tan(0.5f * c.fov_y_degrees * std::numbers::pi_v<float> / 180.0f);
  const float n = c.near_plane, f = c.far_plane;
  Mat4f m = Mat4f::Zero();
  m(0, 0) = t / aspect;
  m(1, 1) = t;
  m(2, 2) = (f + n) / (n - f);
  m(2, 3) = 2.0f * f * n / (n - f);
  m(3, 2) = -1.0f;
  return m;
}

Camera frame_box(const Eigen::AlignedBox3f& box, const Vec3f& direction, const Vec3f& up, float fov_y_degrees,
                 float aspect) {
  Camera c;
  c.up = up.normalized();
  c.fov_y_degrees = fov_y_degrees;
  c.target = box.center();
  const float radius = std::max(0.5f * box.diagonal().norm(), 1e-3f);
  const float half_fov = 0.5f * std::min(fov_y_degrees, fov_y_degrees * aspect) * std::numbers::pi_v<float> / 180.0f;
  const float distance = radius / std::sin(half_fov);
  c.eye = c.target - distance * direction.normalized();
  if (std::abs(direction.normalized().dot(c.up)) > 0.99f) c.up = c.up.unitOrthogonal();
  c.near_plane = std::max(distance - 4.0f * radius, 1e-3f * distance);
  c.far_plane = distance + 40.0f * radius;
  return c;
}

}  // namespace fissure::render
