#include "player/render/ground.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>

#include "player/render/camera_math.h"

namespace fissure::render {

namespace {

/// The shadow map's side: the power of two at or below the casters' diameter on screen
/// in pixels, from 256 to 2048 (a finer map only costs llvmpipe fill: the bunny at
/// 1280×720 cast its shadow for 8-9 ms a frame at 512², 12-17 ms at 1024², 40 at 2048²).
int shadow_map_size(const Eigen::AlignedBox3f& casters, const Camera& camera, int image_height) {
  const float radius = 0.5f * casters.diagonal().norm();
  const float distance = std::max((casters.center() - camera.eye).norm() - radius, 0.1f * radius);
  const float half_fov = 0.5f * camera.fov_y_degrees * std::numbers::pi_v<float> / 180.0f;
  const float diameter = radius * static_cast<float>(image_height) / (distance * std::tan(half_fov));  // [pixels]
  // NaN (no caster in view, or the eye on the casters' centre) takes the smallest map.
  const float clamped = diameter >= 256.0f ? std::min(diameter, 2048.0f) : 256.0f;
  const auto wanted = static_cast<unsigned>(clamped);
  return static_cast<int>(std::bit_floor(wanted));  // the 2×2 filter hides the coarser texels
}

/// World → [0, 1]³ of an orthographic view along the light that holds a sphere around
/// the casters.
Mat4f light_matrix(const Eigen::AlignedBox3f& casters, const Light& light) {
  const float radius = std::max(0.5f * casters.diagonal().norm(), 1e-4f);
  Camera view;
  view.target = casters.center();
  view.eye = view.target + 2.0f * radius * light.towards.normalized();
  view.up = std::abs(light.towards.normalized().z()) > 0.9f ? Vec3f::UnitX() : Vec3f::UnitZ();
  const float near = radius, far = 3.0f * radius;
  Mat4f ortho = Mat4f::Identity();
  ortho(0, 0) = ortho(1, 1) = 1.0f / radius;
  ortho(2, 2) = -2.0f / (far - near);
  ortho(2, 3) = -(far + near) / (far - near);
  Mat4f to_unit = Mat4f::Identity();  // clip [-1, 1]³ → texture [0, 1]³
  to_unit.topLeftCorner<3, 3>() *= 0.5f;
  to_unit.topRightCorner<3, 1>().setConstant(0.5f);
  return to_unit * ortho * look_at(view);
}

Eigen::AlignedBox3f casters_bounds(const std::vector<std::unique_ptr<EmbeddedBody>>& bodies,
                                   const std::vector<std::unique_ptr<PlainBody>>& plains) {
  Eigen::AlignedBox3f box;
  for (const auto& body : bodies) {
    if (body->visible && body->posed && !body->bounds.isEmpty()) box.extend(body->bounds);
  }
  for (const auto& plain : plains) {
    if (!plain->visible || plain->local_bounds.isEmpty()) continue;
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3f p = plain->local_bounds.corner(static_cast<Eigen::AlignedBox3f::CornerType>(corner));
      box.extend((plain->transform * p.homogeneous()).head<3>());
    }
  }
  return box;
}

}  // namespace

GroundPass::GroundPass()
    : m_sky({embedded_shader("sky.vert.glsl"), embedded_shader("sky.frag.glsl")}),
      m_ground({embedded_shader("ground.vert.glsl"), embedded_shader("ground.frag.glsl")}),
      m_shadow_embedded({embedded_shader("shadow_embedded.vert.glsl"), embedded_shader("shadow_embedded.frag.glsl")}),
      m_shadow_plain({embedded_shader("plain.vert.glsl"), embedded_shader("shadow.frag.glsl")}) {}

GroundPass::~GroundPass() {
  if (m_map != 0) glDeleteTextures(1, &m_map);
}

void GroundPass::resize_map(int size) {
  if (size == m_size) return;
  if (m_map != 0) glDeleteTextures(1, &m_map);
  glCreateTextures(GL_TEXTURE_2D, 1, &m_map);
  glTextureStorage2D(m_map, 1, GL_DEPTH_COMPONENT24, size, size);
  glTextureParameteri(m_map, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(m_map, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  // Beyond the map nothing casts: the border is the far plane's depth.
  glTextureParameteri(m_map, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_BORDER);
  glTextureParameteri(m_map, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_BORDER);
  const float far[4] = {1.0f, 1.0f, 1.0f, 1.0f};
  glTextureParameterfv(m_map, GL_TEXTURE_BORDER_COLOR, far);
  glTextureParameteri(m_map, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
  glTextureParameteri(m_map, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
  glNamedFramebufferTexture(m_framebuffer.get(), GL_DEPTH_ATTACHMENT, m_map, 0);
  glNamedFramebufferDrawBuffer(m_framebuffer.get(), GL_NONE);
  glNamedFramebufferReadBuffer(m_framebuffer.get(), GL_NONE);
  m_size = size;
}

void GroundPass::render_shadow_map(const std::vector<std::unique_ptr<EmbeddedBody>>& bodies,
                                   const std::vector<std::unique_ptr<PlainBody>>& plains, const Light& light,
                                   const Camera& camera, int image_height) {
  Eigen::AlignedBox3f casters = casters_bounds(bodies, plains);
  if (casters.isEmpty()) casters.extend(camera.target);
  resize_map(shadow_map_size(casters, camera, image_height));
  m_shadow_matrix = light_matrix(casters, light);
  glBindFramebuffer(GL_FRAMEBUFFER, m_framebuffer.get());
  glViewport(0, 0, m_size, m_size);
  glClear(GL_DEPTH_BUFFER_BIT);
  // Clip space of the map: texture coordinates back to [-1, 1].
  Mat4f to_clip = Mat4f::Identity();
  to_clip.topLeftCorner<3, 3>() *= 2.0f;
  to_clip.topRightCorner<3, 1>().setConstant(-1.0f);
  const Mat4f light_view_projection = to_clip * m_shadow_matrix;
  m_shadow_embedded.use();
  glUniformMatrix4fv(m_shadow_embedded.uniform("view_projection"), 1, GL_FALSE, light_view_projection.data());
  for (const auto& body : bodies) {
    if (!body->visible || !body->posed || body->corners == 0) continue;
    body->nodes.bind(0);
    body->tets.bind(1);
    glBindVertexArray(body->vertex_array.get());
    glDrawElements(GL_TRIANGLES, body->corners, GL_UNSIGNED_INT, nullptr);
  }
  m_shadow_plain.use();
  glUniformMatrix4fv(m_shadow_plain.uniform("view_projection"), 1, GL_FALSE, light_view_projection.data());
  for (const auto& plain : plains) {
    if (!plain->visible || plain->index_count == 0) continue;
    glUniformMatrix4fv(m_shadow_plain.uniform("model"), 1, GL_FALSE, plain->transform.data());
    glBindVertexArray(plain->vertex_array.get());
    glDrawElements(GL_TRIANGLES, plain->index_count, GL_UNSIGNED_INT, nullptr);
  }
}

void GroundPass::draw_sky(const Mat4f& view_projection, const Vec3f& up, const Sky& sky) const {
  m_sky.use();
  const Mat4f inverse = view_projection.inverse();
  glUniformMatrix4fv(m_sky.uniform("inverse_view_projection"), 1, GL_FALSE, inverse.data());
  glUniform3fv(m_sky.uniform("up"), 1, up.normalized().eval().data());
  glUniform3fv(m_sky.uniform("horizon"), 1, sky.horizon.data());
  glUniform3fv(m_sky.uniform("zenith"), 1, sky.zenith.data());
  glDepthMask(GL_FALSE);  // at the far plane, behind everything drawn (GL_LEQUAL)
  glBindVertexArray(m_empty_vertex_array.get());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glDepthMask(GL_TRUE);
}

void GroundPass::draw_ground(const Mat4f& view_projection, const Camera& camera, const Light& light,
                             const Ground& ground, const Sky& sky, bool shadows) const {
  const Vec3f n = ground.normal.normalized();
  const Vec3f u = n.unitOrthogonal(), v = n.cross(u);
  const Vec3f centre = camera.target - (n.dot(camera.target) - ground.offset) * n;
  m_ground.use();
  glUniformMatrix4fv(m_ground.uniform("view_projection"), 1, GL_FALSE, view_projection.data());
  glUniform3fv(m_ground.uniform("centre"), 1, centre.data());
  glUniform3fv(m_ground.uniform("axis_u"), 1, u.data());
  glUniform3fv(m_ground.uniform("axis_v"), 1, v.data());
  glUniform3fv(m_ground.uniform("normal"), 1, n.data());
  // As far as the far plane reaches, faded out before it: the ground never ends in an
  // edge, it turns into the horizon.
  glUniform1f(m_ground.uniform("half_size"), camera.far_plane);
  // The fade starts at twice the target's distance, so the far ground shows the air's
  // depth even when the horizon is out of view.
  const float fog_start = std::min(2.0f * (camera.target - camera.eye).norm(), 0.5f * camera.far_plane);
  glUniform2f(m_ground.uniform("fog"), fog_start, 0.9f * camera.far_plane);
  glUniform1f(m_ground.uniform("cell"), std::max(ground.cell, 1e-6f));
  glUniform3fv(m_ground.uniform("base_color"), 1, ground.color.data());
  glUniform3fv(m_ground.uniform("eye"), 1, camera.eye.data());
  glUniform3fv(m_ground.uniform("light_towards"), 1, light.towards.data());
  glUniform1f(m_ground.uniform("ambient"), light.ambient);
  glUniform3fv(m_ground.uniform("horizon"), 1, sky.horizon.data());
  glUniform1i(m_ground.uniform("shadows"), shadows && m_map != 0 ? 1 : 0);
  glUniformMatrix4fv(m_ground.uniform("shadow_matrix"), 1, GL_FALSE, m_shadow_matrix.data());
  glUniform1i(m_ground.uniform("shadow_map"), 3);
  glBindTextureUnit(3, m_map);
  glBindVertexArray(m_empty_vertex_array.get());
  glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
}

}  // namespace fissure::render
