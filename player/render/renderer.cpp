#include "player/render/renderer.h"

#include <glad/gl.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <optional>
#include <string>

#include "common/error.h"
#include "player/render/camera_math.h"
#include "player/render/gpu_buffer.h"
#include "player/render/gpu_meshes.h"
#include "player/render/ground.h"
#include "player/render/shader_program.h"
#include "player/render/shapes.h"

namespace fissure::render {

namespace {

void check_size(int width, int height) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384) {
    throw Error("image size " + std::to_string(width) + "×" + std::to_string(height) + " is out of range",
                "use a size from 1×1 to 16384×16384, e.g. --size 1280x720");
  }
}

}  // namespace

struct Renderer::Impl {
  int width, height;
  GlName framebuffer{GlName::Kind::Framebuffer};
  GlName color{GlName::Kind::Renderbuffer};
  GlName depth{GlName::Kind::Renderbuffer};
  ShaderProgram embedded, plain, wall, wall_tessellated, cage, sphere;
  GlName empty_vertex_array{GlName::Kind::VertexArray};  ///< walls read everything from storage buffers
  bool walls_visible = true, normal_mapping = true, fragment_colors = false, cage_visible = false;
  bool spheres_visible = false, replication_colors = false;
  std::unique_ptr<PlainBody> debug_sphere;  ///< the unit sphere the sphere view instances
  float tessellation_level = 1.0f, pixels_per_segment = 8.0f;  ///< level ≤ 1: walls drawn flat
  std::vector<std::unique_ptr<EmbeddedBody>> bodies;
  std::vector<std::unique_ptr<PlainBody>> plains;
  Camera camera;
  Light light;
  Sky sky;
  std::optional<Ground> ground;
  bool shadows = true;
  std::unique_ptr<GroundPass> ground_pass;  ///< made when a ground is first set
  RenderStats stats;
  std::size_t pending_upload = 0;

  Impl(int w, int h)
      : width(w),
        height(h),
        embedded({embedded_shader("embedded.vert.glsl"), embedded_shader("embedded.frag.glsl"),
                  embedded_shader("lighting.frag.glsl")}),
        plain({embedded_shader("plain.vert.glsl"), embedded_shader("plain.frag.glsl"),
               embedded_shader("lighting.frag.glsl")}),
        wall({embedded_shader("wall.vert.glsl"), embedded_shader("wall.frag.glsl"),
              embedded_shader("lighting.frag.glsl")}),
        wall_tessellated({embedded_shader("wall.vert.glsl"), embedded_shader("wall.tesc.glsl"),
                          embedded_shader("wall.tese.glsl"), embedded_shader("wall.frag.glsl"),
                          embedded_shader("lighting.frag.glsl")}),
        cage({embedded_shader("cage.vert.glsl"), embedded_shader("cage.frag.glsl")}),
        sphere({embedded_shader("sphere.vert.glsl"), embedded_shader("plain.frag.glsl"),
                embedded_shader("lighting.frag.glsl")}) {
    make_target(w, h);
  }

  /// (Re)allocates the framebuffer's colour and depth storage.
  void make_target(int w, int h) {
    // Storage made by glNamedRenderbufferStorage may be respecified: a resize reuses the names.
    glNamedRenderbufferStorage(color.get(), GL_RGBA8, w, h);
    glNamedRenderbufferStorage(depth.get(), GL_DEPTH_COMPONENT24, w, h);
    glNamedFramebufferRenderbuffer(framebuffer.get(), GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color.get());
    glNamedFramebufferRenderbuffer(framebuffer.get(), GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth.get());
    if (glCheckNamedFramebufferStatus(framebuffer.get(), GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      throw Error("the render target (" + std::to_string(w) + "×" + std::to_string(h) + ") is incomplete",
                  "try a smaller --size");
    }
    width = w;
    height = h;
  }

  void set_common_uniforms(const ShaderProgram& program, const Mat4f& view_projection) const {
    program.use();
    glUniformMatrix4fv(program.uniform("view_projection"), 1, GL_FALSE, view_projection.data());
    glUniform3fv(program.uniform("eye"), 1, camera.eye.data());
    glUniform3fv(program.uniform("light_towards"), 1, light.towards.data());
    glUniform1f(program.uniform("ambient"), light.ambient);
  }

  void draw_bodies(const Mat4f& view_projection) {
    set_common_uniforms(embedded, view_projection);
    glUniform1i(embedded.uniform("fragment_colors"), fragment_colors ? 1 : 0);
    glUniform1i(embedded.uniform("replication_colors"), replication_colors ? 1 : 0);
    std::array<Vec3f, 5> palette;
    for (std::uint32_t k = 0; k < palette.size(); ++k) palette[k] = replication_color(k + 1);
    glUniform3fv(embedded.uniform("replication_palette"), 5, palette[0].data());
    for (const auto& body : bodies) {
      if (!body->visible || !body->posed || body->corners == 0 || spheres_visible) continue;
      glUniform3fv(embedded.uniform("base_color"), 1, body->color.data());
      body->nodes.bind(0);
      body->tets.bind(1);
      body->rest_inverse.bind(2);
      body->fragments.bind(7);
      body->replicas.bind(10);
      glBindVertexArray(body->vertex_array.get());
      glDrawElements(GL_TRIANGLES, body->corners, GL_UNSIGNED_INT, nullptr);
    }
  }

  /// The walls fracture opened: one triangle per wall, or one patch per wall when
  /// tessellation is on (wall.tesc.glsl splits only the walls that have relief).
  void draw_walls(const Mat4f& view_projection) {
    if (!walls_visible || spheres_visible) return;
    const bool tessellate = tessellation_level > 1.0f;
    const ShaderProgram& program = tessellate ? wall_tessellated : wall;
    set_common_uniforms(program, view_projection);
    glUniform1i(program.uniform("tiles"), 0);
    glUniform1i(program.uniform("detail_normal"), 1);
    if (tessellate) {
      glUniform1i(program.uniform("detail_height"), 2);
      glUniform1f(program.uniform("max_level"), tessellation_level);
      glUniform1f(program.uniform("pixels_per_segment"), pixels_per_segment);
      glUniform2f(program.uniform("viewport"), static_cast<float>(width), static_cast<float>(height));
      glPatchParameteri(GL_PATCH_VERTICES, 3);
    }
    glBindVertexArray(empty_vertex_array.get());
    // A wall meets its body's surface along the contour at the same depth: pushed back
    // by one depth step of its own slope, it loses those ties to the surface instead of
    // showing through it as a dotted line (issue 44; decisions/0050).
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.0f, 1.0f);
    for (const auto& body : bodies) {
      if (!body->visible || !body->posed || body->wall_count == 0) continue;
      glUniform3fv(program.uniform("base_color"), 1, body->interior_color.data());
      glUniform2i(program.uniform("tile_layout"), body->atlas.resolution, body->atlas.cells);
      glUniform1i(program.uniform("detail_resolution"), body->detail_resolution);
      glUniform1f(program.uniform("solid_threshold"), body->solid_threshold);
      glBindTextureUnit(0, body->tiles);
      glBindTextureUnit(1, body->detail);
      glBindTextureUnit(2, body->height);
      glUniform1i(program.uniform("normal_mapping"), normal_mapping && body->detail != 0 ? 1 : 0);
      body->detail_repeat.bind(6);
      body->relief.bind(8);
      body->nodes.bind(0);
      body->tets.bind(1);
      body->walls.bind(3);
      body->face_tile.bind(4);
      body->face_uv.bind(5);
      glDrawArrays(tessellate ? GL_PATCHES : GL_TRIANGLES, 0, 3 * body->wall_count);
    }
    glDisable(GL_POLYGON_OFFSET_FILL);
  }

  void draw_cages(const Mat4f& view_projection) {
    if (!cage_visible) return;
    cage.use();
    glUniformMatrix4fv(cage.uniform("view_projection"), 1, GL_FALSE, view_projection.data());
    const Vec3f color(0.15f, 0.25f, 0.55f);
    glUniform3fv(cage.uniform("base_color"), 1, color.data());
    glBindVertexArray(empty_vertex_array.get());
    for (const auto& body : bodies) {
      if (!body->visible || !body->posed) continue;
      body->nodes.bind(0);
      body->tets.bind(1);
      glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(12 * (body->tets.size() / (4 * sizeof(std::uint32_t)))));
    }
  }

  /// The collision-sphere view: one instanced draw of the unit sphere per body.
  void draw_spheres(const Mat4f& view_projection) {
    if (!spheres_visible) return;
    if (!debug_sphere) debug_sphere = upload_plain(unit_sphere(kDebugSphereRings, kDebugSphereSegments));
    set_common_uniforms(sphere, view_projection);
    glBindVertexArray(debug_sphere->vertex_array.get());
    for (const auto& body : bodies) {
      if (!body->visible || !body->posed || body->sphere_count == 0) continue;
      glUniform3fv(sphere.uniform("base_color"), 1, body->sphere_color.data());
      body->nodes.bind(0);
      body->tets.bind(1);
      body->spheres.bind(9);
      glDrawElementsInstanced(GL_TRIANGLES, debug_sphere->index_count, GL_UNSIGNED_INT, nullptr, body->sphere_count);
    }
  }

  void draw_plains(const Mat4f& view_projection) {
    set_common_uniforms(plain, view_projection);
    for (const auto& mesh : plains) {
      if (!mesh->visible || mesh->index_count == 0) continue;
      glUniform3fv(plain.uniform("base_color"), 1, mesh->color.data());
      glUniformMatrix4fv(plain.uniform("model"), 1, GL_FALSE, mesh->transform.data());
      glBindVertexArray(mesh->vertex_array.get());
      glDrawElements(GL_TRIANGLES, mesh->index_count, GL_UNSIGNED_INT, nullptr);
    }
  }
};

Renderer::Renderer(int width, int height) {
  check_size(width, height);
  m_impl = std::make_unique<Impl>(width, height);
}

Renderer::~Renderer() = default;

int Renderer::width() const { return m_impl->width; }
int Renderer::height() const { return m_impl->height; }

std::size_t Renderer::add_body(const EmbeddedMesh& mesh) {
  m_impl->bodies.push_back(upload_embedded(mesh, m_impl->pending_upload));
  return m_impl->bodies.size() - 1;
}

void Renderer::set_pose(std::size_t index, const BodyPose& pose) {
  m_impl->pending_upload += upload_pose(*m_impl->bodies.at(index), pose);
}

std::size_t Renderer::add_plain(const PlainMesh& mesh) {
  auto body = upload_plain(mesh);
  m_impl->pending_upload += body->upload_bytes;
  m_impl->plains.push_back(std::move(body));
  return m_impl->plains.size() - 1;
}

void Renderer::set_transform(std::size_t plain, const Mat4f& transform) { m_impl->plains.at(plain)->transform = transform; }
void Renderer::set_visible(std::size_t plain, bool visible) { m_impl->plains.at(plain)->visible = visible; }
void Renderer::set_body_visible(std::size_t body, bool visible) { m_impl->bodies.at(body)->visible = visible; }
void Renderer::set_walls_visible(bool visible) { m_impl->walls_visible = visible; }
void Renderer::set_normal_mapping(bool enabled) { m_impl->normal_mapping = enabled; }
void Renderer::set_fragment_colors(bool enabled) { m_impl->fragment_colors = enabled; }
void Renderer::set_tessellation(float max_level, float pixels_per_segment) {
  GLint limit = 64;  // the least GL 4.5 allows
  glGetIntegerv(GL_MAX_TESS_GEN_LEVEL, &limit);
  m_impl->tessellation_level = std::clamp(max_level, 1.0f, static_cast<float>(limit));
  m_impl->pixels_per_segment = std::max(pixels_per_segment, 0.5f);
}
void Renderer::set_cage_visible(bool visible) { m_impl->cage_visible = visible; }
void Renderer::set_spheres_visible(bool visible) { m_impl->spheres_visible = visible; }
void Renderer::set_replication_colors(bool enabled) { m_impl->replication_colors = enabled; }

Vec3f replication_color(std::uint32_t replicas) {
  static const std::array<Vec3f, 5> palette{Vec3f(0.62f, 0.74f, 0.58f), Vec3f(0.93f, 0.82f, 0.36f),
                                            Vec3f(0.93f, 0.55f, 0.22f), Vec3f(0.84f, 0.24f, 0.20f),
                                            Vec3f(0.55f, 0.22f, 0.62f)};
  return palette[std::clamp<std::uint32_t>(replicas, 1, 5) - 1];
}
void Renderer::set_camera(const Camera& camera) { m_impl->camera = camera; }
void Renderer::set_light(const Light& light) { m_impl->light = light; }
void Renderer::set_background(const Vec3f& color) { m_impl->sky = {color, color}; }
void Renderer::set_sky(const Sky& sky) { m_impl->sky = sky; }
void Renderer::set_ground(const Ground& ground) {
  if (!m_impl->ground_pass) m_impl->ground_pass = std::make_unique<GroundPass>();
  m_impl->ground = ground;
}
void Renderer::set_shadows(bool enabled) { m_impl->shadows = enabled; }
const RenderStats& Renderer::last_stats() const { return m_impl->stats; }

void Renderer::resize(int width, int height) {
  check_size(width, height);
  if (width != m_impl->width || height != m_impl->height) m_impl->make_target(width, height);
}

void Renderer::draw() {
  const auto start = std::chrono::steady_clock::now();
  Impl& r = *m_impl;
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  glDisable(GL_SCISSOR_TEST);
  const bool shadows = r.ground && r.shadows;
  if (shadows) r.ground_pass->render_shadow_map(r.bodies, r.plains, r.light, r.camera, r.height);
  glBindFramebuffer(GL_FRAMEBUFFER, r.framebuffer.get());
  glViewport(0, 0, r.width, r.height);
  glClearColor(r.sky.horizon.x(), r.sky.horizon.y(), r.sky.horizon.z(), 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  const Mat4f view_projection =
      perspective(r.camera, static_cast<float>(r.width) / static_cast<float>(r.height)) * look_at(r.camera);
  if (r.ground) r.ground_pass->draw_ground(view_projection, r.camera, r.light, *r.ground, r.sky, shadows);
  r.draw_plains(view_projection);
  r.draw_bodies(view_projection);
  r.draw_walls(view_projection);
  r.draw_spheres(view_projection);
  r.draw_cages(view_projection);
  if (r.sky.zenith != r.sky.horizon) {
    if (!r.ground_pass) r.ground_pass = std::make_unique<GroundPass>();
    r.ground_pass->draw_sky(view_projection, r.ground ? r.ground->normal : r.camera.up, r.sky);
  }
  const GLenum error = glGetError();
  if (error != GL_NO_ERROR) {
    throw Error("OpenGL error 0x" + std::to_string(error) + " while drawing", "this is a bug; please report it");
  }
  r.stats.upload_bytes = std::exchange(r.pending_upload, 0);
  r.stats.draw_ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void Renderer::read(std::vector<std::uint8_t>& rgba) const {
  const Impl& r = *m_impl;
  const std::size_t row = 4 * static_cast<std::size_t>(r.width);
  rgba.resize(row * static_cast<std::size_t>(r.height));
  glBindFramebuffer(GL_READ_FRAMEBUFFER, r.framebuffer.get());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, r.width, r.height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  // GL's rows start at the bottom; images start at the top.
  for (int y = 0; y < r.height / 2; ++y) {
    std::swap_ranges(rgba.begin() + static_cast<std::ptrdiff_t>(y * row),
                     rgba.begin() + static_cast<std::ptrdiff_t>((y + 1) * row),
                     rgba.begin() + static_cast<std::ptrdiff_t>((r.height - 1 - y) * row));
  }
}

void Renderer::render(std::vector<std::uint8_t>& rgba) {
  const auto start = std::chrono::steady_clock::now();
  draw();
  read(rgba);
  // draw_ms counts the read-back too: with it the GPU's work is finished, not queued.
  m_impl->stats.draw_ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void Renderer::present(int width, int height) const {
  glBlitNamedFramebuffer(m_impl->framebuffer.get(), 0, 0, 0, m_impl->width, m_impl->height, 0, 0, width, height,
                         GL_COLOR_BUFFER_BIT, GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glViewport(0, 0, width, height);
}

}  // namespace fissure::render
