#pragma once
/// The scene's surroundings (issue 44): a sky that turns from the horizon's colour to
/// the zenith's, a ground plane with a faint checker in world units that fades into the
/// horizon, and the shadows that bodies, fragments and projectiles cast on it (a shadow
/// map fitted to them each frame). Internal to player/render; needs a current context.

#include <glad/gl.h>

#include <memory>
#include <vector>

#include "player/render/gpu_buffer.h"
#include "player/render/gpu_meshes.h"
#include "player/render/renderer.h"
#include "player/render/shader_program.h"

namespace fissure::render {

class GroundPass {
 public:
  GroundPass();
  ~GroundPass();
  GroundPass(const GroundPass&) = delete;
  GroundPass& operator=(const GroundPass&) = delete;

  /// Renders the casters' depth as the light sees them into the shadow map, at most a
  /// texel per pixel of their diameter on screen; leaves the map's framebuffer bound.
  void render_shadow_map(const std::vector<std::unique_ptr<EmbeddedBody>>& bodies,
                         const std::vector<std::unique_ptr<PlainBody>>& plains, const Light& light, const Camera& camera,
                         int image_height);
  /// The sky wherever nothing was drawn (call it last: it is at the far plane, depth
  /// tested and not written).
  void draw_sky(const Mat4f& view_projection, const Vec3f& up, const Sky& sky) const;
  /// The ground, shadowed when `shadows` (after render_shadow_map in the same frame).
  void draw_ground(const Mat4f& view_projection, const Camera& camera, const Light& light, const Ground& ground,
                   const Sky& sky, bool shadows) const;
  /// The shadow map's side [texels] as last rendered (0 before).
  [[nodiscard]] int shadow_size() const { return m_size; }

 private:
  void resize_map(int size);

  ShaderProgram m_sky, m_ground, m_shadow_embedded, m_shadow_plain;
  GlName m_empty_vertex_array{GlName::Kind::VertexArray};
  GlName m_framebuffer{GlName::Kind::Framebuffer};
  GLuint m_map = 0;
  int m_size = 0;
  Mat4f m_shadow_matrix = Mat4f::Identity();  ///< world → [0, 1]³ of the map
};

}  // namespace fissure::render
