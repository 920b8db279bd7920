#include "player/render/renderer.h"

#include <glad/gl.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <unordered_map>
#include <chrono>
#include <cmath>
#include <numbers>

#include "common/error.h"
#include "player/render/gpu_buffer.h"
#include "player/render/shader_program.h"
#include "player/render/shapes.h"

namespace fissure::render {

namespace {

/// One corner of an embedded instance, as the vertex shader reads it.
struct EmbeddedCorner {
  float barycentric[4];
  std::uint32_t tet;
  float rest_normal[3];
};
static_assert(sizeof(EmbeddedCorner) == 32);

/// A corner's bits, to find identical corners.
using CornerKey = std::array<std::uint32_t, sizeof(EmbeddedCorner) / 4>;
CornerKey key_of(const EmbeddedCorner& c) {
  CornerKey key;
  std::memcpy(key.data(), &c, sizeof c);
  return key;
}
struct CornerKeyHash {
  std::size_t operator()(const CornerKey& key) const {
    std::size_t h = 1469598103934665603ull;
    for (const std::uint32_t word : key) h = (h ^ word) * 1099511628211ull;
    return h;
  }
};

/// How far inside the exact contour a crossing wall stops, in tile texels. The tile's
/// distance is exact at texel centres, but linear filtering rounds the contour's reflex
/// corners outward by a fraction of a texel, and a wall that reaches past the surface
/// shows through it near the seam or past the silhouette (issue 44: 90-170 specks in a
/// 480² view of a sphere split along every face, unmoved). Half a texel removes all of
/// them in six views (a quarter leaves 2-5); the gap it leaves between a wall and its
/// own surface in an open crack is sub-pixel at the sample's sizes (decisions/0050).
constexpr float kWallErosionTexels = 0.5f;

/// BodyPose::faces' value of a face fracture opened (sim::FaceState::Fractured).
constexpr std::uint8_t kFaceFractured = 2;

/// How the signed-distance tiles are packed: a texture array whose layers each hold a
/// square grid of tiles (a cage of 10k tets has ~6,000 tiles, more than the 2,048
/// layers a GL implementation must offer, and far fewer than a layer of 4096² holds).
struct TileAtlas {
  int resolution = 0, cells = 1, layers = 0;  ///< tile side [texels], tiles per layer side, layers
};

/// Linear magnification, `min_filter` minification, `wrap` on both axes.
void set_sampling(GLuint texture, GLenum min_filter, GLenum wrap) {
  glTextureParameteri(texture, GL_TEXTURE_MIN_FILTER, static_cast<GLint>(min_filter));
  glTextureParameteri(texture, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(texture, GL_TEXTURE_WRAP_S, static_cast<GLint>(wrap));
  glTextureParameteri(texture, GL_TEXTURE_WRAP_T, static_cast<GLint>(wrap));
}

/// One of the walls' detail maps (normal: 3 channels, height: 1): tileable, so it
/// repeats; mipmapped, so far walls do not shimmer and coarse relief does not alias.
GLuint upload_detail(int res, const std::vector<std::uint8_t>& texels, int channels) {
  if (res <= 0 || texels.size() != static_cast<std::size_t>(channels) * res * res) return 0;
  GLuint texture = 0;
  glCreateTextures(GL_TEXTURE_2D, 1, &texture);
  const int levels = 1 + static_cast<int>(std::floor(std::log2(static_cast<double>(res))));
  glTextureStorage2D(texture, levels, channels == 3 ? GL_RGB8 : GL_R8, res, res);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage2D(texture, 0, 0, 0, res, res, channels == 3 ? GL_RGB : GL_RED, GL_UNSIGNED_BYTE, texels.data());
  glGenerateTextureMipmap(texture);
  set_sampling(texture, GL_LINEAR_MIPMAP_LINEAR, GL_REPEAT);
  return texture;
}

/// A collision sphere as sphere.vert.glsl reads it (std430).
struct SphereData {
  float barycentric[4];
  std::uint32_t tet;
  float radius;
  float padding[2];
};
static_assert(sizeof(SphereData) == 32);

struct EmbeddedBody {
  GlName vertices{GlName::Kind::Buffer};
  GlName indices{GlName::Kind::Buffer};
  GlName vertex_array{GlName::Kind::VertexArray};
  GLsizei corners = 0;
  Vec3f color, interior_color;
  StorageBuffer nodes, tets, rest_inverse;
  std::uint64_t topology_version = ~std::uint64_t{0};
  bool posed = false, visible = true;
  // Walls: the static per-slot tables and tiles, and the slots fracture opened.
  StorageBuffer face_tile, face_uv, walls, detail_repeat, fragments, relief;
  // Debug views: per instance its triangle's replica count; the collision spheres.
  StorageBuffer replicas, spheres;
  GLsizei sphere_count = 0;
  Vec3f sphere_color;
  GLuint detail = 0;  ///< GL_TEXTURE_2D (RGB8, repeating, mipmapped), 0 without a detail material
  GLuint height = 0;  ///< GL_TEXTURE_2D (R8, repeating, mipmapped), 0 without relief
  int detail_resolution = 0;
  std::vector<std::int32_t> face_tile_host;
  GLsizei wall_count = 0;
  GLuint tiles = 0;  ///< GL_TEXTURE_2D_ARRAY, 0 without tiles
  TileAtlas atlas;
  float solid_threshold = 127.5f / 255.0f;  ///< the wall shader's least drawn distance (kWallErosionTexels)
  ~EmbeddedBody() {
    if (tiles != 0) glDeleteTextures(1, &tiles);
    if (detail != 0) glDeleteTextures(1, &detail);
    if (height != 0) glDeleteTextures(1, &height);
  }
};

TileAtlas plan_atlas(int resolution, std::size_t tiles) {
  GLint max_size = 0, max_layers = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
  TileAtlas atlas{resolution, 1, 0};
  const int cap = std::max(1, std::min(max_size, 4096) / resolution);
  atlas.cells = std::clamp(static_cast<int>(std::ceil(std::sqrt(static_cast<double>(tiles)))), 1, cap);
  const std::size_t per_layer = static_cast<std::size_t>(atlas.cells) * atlas.cells;
  atlas.layers = static_cast<int>((tiles + per_layer - 1) / per_layer);
  if (atlas.layers > max_layers) {
    throw Error(std::to_string(tiles) + " wall tiles of " + std::to_string(resolution) + "² texels do not fit the GPU's textures",
                "rebake with a smaller --wall-res");
  }
  return atlas;
}

/// The signed-distance tiles in a texture array (see TileAtlas), filtered linearly; the
/// wall shader clamps its samples inside each tile, so neighbours never bleed in.
GLuint upload_tiles(const EmbeddedMesh& mesh, TileAtlas& atlas) {
  const int res = mesh.tile_resolution;
  if (res <= 0 || mesh.tiles.empty()) return 0;
  const std::size_t tile_bytes = static_cast<std::size_t>(res) * res;
  const std::size_t count = mesh.tiles.size() / tile_bytes;
  atlas = plan_atlas(res, count);
  const int side = atlas.cells * res;
  GLuint texture = 0;
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &texture);
  glTextureStorage3D(texture, 1, GL_R8, side, side, atlas.layers);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  const std::size_t per_layer = static_cast<std::size_t>(atlas.cells) * atlas.cells;
  for (std::size_t tile = 0; tile < count; ++tile) {
    const auto cell = static_cast<int>(tile % per_layer);
    glTextureSubImage3D(texture, 0, (cell % atlas.cells) * res, (cell / atlas.cells) * res,
                        static_cast<int>(tile / per_layer), res, res, 1, GL_RED, GL_UNSIGNED_BYTE,
                        mesh.tiles.data() + tile * tile_bytes);
  }
  set_sampling(texture, GL_LINEAR, GL_CLAMP_TO_EDGE);
  return texture;
}

struct PlainBody {
  GlName vertices{GlName::Kind::Buffer};
  GlName indices{GlName::Kind::Buffer};
  GlName vertex_array{GlName::Kind::VertexArray};
  GLsizei index_count = 0;
  Vec3f color;
  Mat4f transform = Mat4f::Identity();
  bool visible = true;
  std::size_t upload_bytes = 0;  ///< what making it sent to the GPU
};

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

void set_vertex_attribute(GLuint vao, GLuint index, GLint size, GLenum type, GLuint offset, bool integer) {
  glEnableVertexArrayAttrib(vao, index);
  if (integer) {
    glVertexArrayAttribIFormat(vao, index, size, type, offset);
  } else {
    glVertexArrayAttribFormat(vao, index, size, type, GL_FALSE, offset);
  }
  glVertexArrayAttribBinding(vao, index, 0);
}

/// A plain mesh's buffers, interleaved position and normal per vertex.
std::unique_ptr<PlainBody> upload_plain(const PlainMesh& mesh) {
  if (mesh.normals.size() != mesh.positions.size() || mesh.positions.size() % 3 != 0 || mesh.triangles.size() % 3 != 0) {
    throw Error("plain mesh: positions, normals and triangles do not match", "give 3 values per vertex and per triangle");
  }
  auto body = std::make_unique<PlainBody>();
  std::vector<float> interleaved;
  interleaved.reserve(2 * mesh.positions.size());
  for (std::size_t v = 0; v < mesh.positions.size() / 3; ++v) {
    interleaved.insert(interleaved.end(), &mesh.positions[3 * v], &mesh.positions[3 * v] + 3);
    interleaved.insert(interleaved.end(), &mesh.normals[3 * v], &mesh.normals[3 * v] + 3);
  }
  glNamedBufferStorage(body->vertices.get(), static_cast<GLsizeiptr>(std::max<std::size_t>(1, interleaved.size()) * sizeof(float)),
                       interleaved.empty() ? nullptr : interleaved.data(), 0);
  glNamedBufferStorage(body->indices.get(),
                       static_cast<GLsizeiptr>(std::max<std::size_t>(1, mesh.triangles.size()) * sizeof(std::uint32_t)),
                       mesh.triangles.empty() ? nullptr : mesh.triangles.data(), 0);
  const GLuint vao = body->vertex_array.get();
  glVertexArrayVertexBuffer(vao, 0, body->vertices.get(), 0, 6 * sizeof(float));
  glVertexArrayElementBuffer(vao, body->indices.get());
  set_vertex_attribute(vao, 0, 3, GL_FLOAT, 0, false);
  set_vertex_attribute(vao, 1, 3, GL_FLOAT, 3 * sizeof(float), false);
  body->index_count = static_cast<GLsizei>(mesh.triangles.size());
  body->color = mesh.color;
  body->upload_bytes = interleaved.size() * sizeof(float) + mesh.triangles.size() * sizeof(std::uint32_t);
  return body;
}

/// The debug views' static data: the replica count per instance (1 where the mesh
/// gives none) and the collision spheres. Returns the bytes sent.
std::size_t upload_debug_data(const EmbeddedMesh& mesh, EmbeddedBody& body) {
  const std::size_t spheres = mesh.sphere_tet.size();
  if (mesh.sphere_barycentric.size() != 4 * spheres || mesh.sphere_radius.size() != spheres) {
    throw Error("embedded mesh: " + std::to_string(spheres) + " spheres with " +
                    std::to_string(mesh.sphere_barycentric.size()) + " barycentric values and " +
                    std::to_string(mesh.sphere_radius.size()) + " radii",
                "give 4 barycentric values and 1 radius per sphere");
  }
  std::vector<std::uint32_t> replicas = mesh.instance_replicas;
  replicas.resize(static_cast<std::size_t>(body.corners) / 3, 1);
  std::vector<SphereData> data(spheres);
  for (std::size_t k = 0; k < spheres; ++k) {
    std::copy_n(&mesh.sphere_barycentric[4 * k], 4, data[k].barycentric);
    data[k].tet = mesh.sphere_tet[k];
    data[k].radius = mesh.sphere_radius[k];
  }
  body.sphere_count = static_cast<GLsizei>(spheres);
  body.sphere_color = mesh.sphere_color;
  return body.replicas.upload(replicas.data(), replicas.size() * sizeof(std::uint32_t)) +
         body.spheres.upload(data.data(), data.size() * sizeof(SphereData));
}

void check_size(int width, int height) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384) {
    throw Error("image size " + std::to_string(width) + "×" + std::to_string(height) + " is out of range",
                "use a size from 1×1 to 16384×16384, e.g. --size 1280x720");
  }
}

}  // namespace

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
  Vec3f background = Vec3f(0.93f, 0.94f, 0.96f);
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
  const std::size_t corners = mesh.tet.size();
  if (mesh.barycentric.size() != 4 * corners || mesh.rest_normal.size() != 3 * corners || corners % 3 != 0) {
    throw Error("embedded mesh: " + std::to_string(corners) + " corners with " +
                    std::to_string(mesh.barycentric.size()) + " barycentric and " +
                    std::to_string(mesh.rest_normal.size()) + " normal values",
                "give 3 corners per instance, 4 barycentric and 3 normal values per corner");
  }
  // A render vertex is a corner of every instance of its triangles in the same tet:
  // identical corners are stored once and indexed, so each (vertex, tet) is shaded once.
  std::vector<EmbeddedCorner> data;
  std::vector<std::uint32_t> indices(corners);
  std::unordered_map<CornerKey, std::uint32_t, CornerKeyHash> unique;
  unique.reserve(corners);
  for (std::size_t k = 0; k < corners; ++k) {
    EmbeddedCorner c{};
    std::copy_n(&mesh.barycentric[4 * k], 4, c.barycentric);
    c.tet = mesh.tet[k];
    std::copy_n(&mesh.rest_normal[3 * k], 3, c.rest_normal);
    const auto [found, added] = unique.try_emplace(key_of(c), static_cast<std::uint32_t>(data.size()));
    if (added) data.push_back(c);
    indices[k] = found->second;
  }
  auto body = std::make_unique<EmbeddedBody>();
  body->corners = static_cast<GLsizei>(corners);
  body->color = mesh.color;
  const GLuint vao = body->vertex_array.get();
  glNamedBufferStorage(body->vertices.get(), static_cast<GLsizeiptr>(std::max<std::size_t>(1, data.size()) * sizeof(EmbeddedCorner)),
                       data.empty() ? nullptr : data.data(), 0);
  glNamedBufferStorage(body->indices.get(), static_cast<GLsizeiptr>(std::max<std::size_t>(1, corners) * sizeof(std::uint32_t)),
                       indices.empty() ? nullptr : indices.data(), 0);
  glVertexArrayVertexBuffer(vao, 0, body->vertices.get(), 0, sizeof(EmbeddedCorner));
  glVertexArrayElementBuffer(vao, body->indices.get());
  set_vertex_attribute(vao, 0, 4, GL_FLOAT, offsetof(EmbeddedCorner, barycentric), false);
  set_vertex_attribute(vao, 1, 1, GL_UNSIGNED_INT, offsetof(EmbeddedCorner, tet), true);
  set_vertex_attribute(vao, 2, 3, GL_FLOAT, offsetof(EmbeddedCorner, rest_normal), false);
  m_impl->pending_upload += data.size() * sizeof(EmbeddedCorner) + indices.size() * sizeof(std::uint32_t);
  if (mesh.face_uv.size() != 6 * mesh.face_tile.size()) {
    throw Error("embedded mesh: " + std::to_string(mesh.face_tile.size()) + " face slots with " +
                    std::to_string(mesh.face_uv.size()) + " uv values",
                "give 6 uv values per (tet, face) slot");
  }
  body->interior_color = mesh.interior_color;
  m_impl->pending_upload += body->rest_inverse.upload(mesh.rest_inverse.data(), mesh.rest_inverse.size() * sizeof(float));
  body->face_tile_host = mesh.face_tile;
  m_impl->pending_upload += body->face_tile.upload(mesh.face_tile.data(), mesh.face_tile.size() * sizeof(std::int32_t));
  m_impl->pending_upload += body->face_uv.upload(mesh.face_uv.data(), mesh.face_uv.size() * sizeof(float));
  body->tiles = upload_tiles(mesh, body->atlas);
  // A tile byte is 127.5 ± 127 × distance / range (bake/walls.cpp).
  body->solid_threshold = (127.5f + 127.0f * kWallErosionTexels / std::max(mesh.tile_range_texels, 1e-3f)) / 255.0f;
  body->detail = upload_detail(mesh.detail_resolution, mesh.detail_normal, 3);
  std::vector<float> repeat = mesh.face_detail_repeat;
  repeat.resize(2 * mesh.face_tile.size(), 1.0f);
  m_impl->pending_upload += body->detail_repeat.upload(repeat.data(), repeat.size() * sizeof(float)) + mesh.detail_normal.size();
  // Relief needs the height map; without one every wall is drawn flat.
  body->height = upload_detail(mesh.detail_resolution, mesh.detail_height, 1);
  body->detail_resolution = mesh.detail_resolution;
  std::vector<float> relief = body->height != 0 ? mesh.face_relief : std::vector<float>{};
  relief.resize(mesh.face_tile.size(), 0.0f);
  m_impl->pending_upload += body->relief.upload(relief.data(), relief.size() * sizeof(float)) + mesh.detail_height.size();
  m_impl->pending_upload += mesh.tiles.size();
  m_impl->pending_upload += upload_debug_data(mesh, *body);
  m_impl->bodies.push_back(std::move(body));
  return m_impl->bodies.size() - 1;
}

void Renderer::set_pose(std::size_t index, const BodyPose& pose) {
  EmbeddedBody& body = *m_impl->bodies.at(index);
  std::size_t& bytes = m_impl->pending_upload;
  bytes += body.nodes.upload(pose.positions.data(), pose.positions.size_bytes());
  if (pose.topology_version != body.topology_version) {
    bytes += body.tets.upload(pose.tets.data(), pose.tets.size_bytes());
    // The walls: the opened slots that show solid (fracture changes only connectivity,
    // so the per-slot tables made at load time stay valid).
    std::vector<std::uint32_t> walls;
    const std::size_t slots = std::min(pose.faces.size(), body.face_tile_host.size());
    for (std::size_t s = 0; s < slots; ++s) {
      if (pose.faces[s] == kFaceFractured && body.face_tile_host[s] != kWallNone) walls.push_back(static_cast<std::uint32_t>(s));
    }
    bytes += body.walls.upload(walls.data(), walls.size() * sizeof(std::uint32_t));
    bytes += body.fragments.upload(pose.fragment.data(), pose.fragment.size_bytes());
    body.wall_count = static_cast<GLsizei>(walls.size());
    body.topology_version = pose.topology_version;
  }
  body.posed = true;
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
void Renderer::set_background(const Vec3f& color) { m_impl->background = color; }
const RenderStats& Renderer::last_stats() const { return m_impl->stats; }

void Renderer::resize(int width, int height) {
  check_size(width, height);
  if (width != m_impl->width || height != m_impl->height) m_impl->make_target(width, height);
}

void Renderer::draw() {
  const auto start = std::chrono::steady_clock::now();
  Impl& r = *m_impl;
  glBindFramebuffer(GL_FRAMEBUFFER, r.framebuffer.get());
  glViewport(0, 0, r.width, r.height);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  glDisable(GL_SCISSOR_TEST);
  glClearColor(r.background.x(), r.background.y(), r.background.z(), 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  const Mat4f view_projection =
      perspective(r.camera, static_cast<float>(r.width) / static_cast<float>(r.height)) * look_at(r.camera);
  r.draw_plains(view_projection);
  r.draw_bodies(view_projection);
  r.draw_walls(view_projection);
  r.draw_spheres(view_projection);
  r.draw_cages(view_projection);
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
