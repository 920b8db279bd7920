#include "player/render/gpu_meshes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <unordered_map>

#include "common/error.h"

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

void set_vertex_attribute(GLuint vao, GLuint index, GLint size, GLenum type, GLuint offset, bool integer) {
  glEnableVertexArrayAttrib(vao, index);
  if (integer) {
    glVertexArrayAttribIFormat(vao, index, size, type, offset);
  } else {
    glVertexArrayAttribFormat(vao, index, size, type, GL_FALSE, offset);
  }
  glVertexArrayAttribBinding(vao, index, 0);
}

/// The debug views' static data: the replica count per instance (1 where the mesh
/// gives none) and the collision spheres. Returns the bytes sent.
std::size_t upload_debug_data(const EmbeddedMesh& mesh, EmbeddedBody& body) {
  const std::size_t spheres = mesh.sphere_tet.size();  // validate() checked the arrays
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

}  // namespace

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
  for (std::size_t v = 0; v + 2 < mesh.positions.size(); v += 3) body->local_bounds.extend(Vec3f(mesh.positions[v], mesh.positions[v + 1], mesh.positions[v + 2]));
  return body;
}

namespace {

std::string count(std::size_t n) { return std::to_string(n); }

/// Every array of an embedded mesh against the others, before any GPU object is made:
/// a mismatch would otherwise read past a buffer on the GPU, or leave half a body made.
void validate(const EmbeddedMesh& mesh) {
  const std::size_t corners = mesh.tet.size();
  if (mesh.barycentric.size() != 4 * corners || mesh.rest_normal.size() != 3 * corners || corners % 3 != 0) {
    throw Error("embedded mesh: " + count(corners) + " corners with " + count(mesh.barycentric.size()) +
                    " barycentric and " + count(mesh.rest_normal.size()) + " normal values",
                "give 3 corners per instance, 4 barycentric and 3 normal values per corner");
  }
  if (mesh.rest_inverse.size() % 9 != 0) {
    throw Error("embedded mesh: " + count(mesh.rest_inverse.size()) + " rest-inverse values", "give 9 per tet");
  }
  const std::size_t tets = mesh.rest_inverse.size() / 9, slots = mesh.face_tile.size();
  const auto bad_tet = [&](const std::vector<std::uint32_t>& list) {
    return std::any_of(list.begin(), list.end(), [&](std::uint32_t t) { return t >= tets; });
  };
  if (bad_tet(mesh.tet) || bad_tet(mesh.sphere_tet)) {
    throw Error("embedded mesh: a corner or sphere names a tet past the " + count(tets) + " with a rest inverse",
                "give a rest inverse for every tet the instances and spheres name");
  }
  if ((slots != 0 && slots != 4 * tets) || mesh.face_uv.size() != 6 * slots) {
    throw Error("embedded mesh: " + count(slots) + " face slots and " + count(mesh.face_uv.size()) + " uv values for " +
                    count(tets) + " tets",
                "give 4 face slots per tet (or none) and 6 uv values per slot");
  }
  const std::size_t tile_texels = static_cast<std::size_t>(std::max(mesh.tile_resolution, 0)) * std::max(mesh.tile_resolution, 0);
  const std::size_t tiles = tile_texels == 0 ? 0 : mesh.tiles.size() / tile_texels;
  if ((tile_texels == 0 && !mesh.tiles.empty()) || (tile_texels != 0 && mesh.tiles.size() % tile_texels != 0) ||
      std::any_of(mesh.face_tile.begin(), mesh.face_tile.end(),
                  [&](std::int32_t t) { return t < kWallNone || (t >= 0 && static_cast<std::size_t>(t) >= tiles); })) {
    throw Error("embedded mesh: the face slots name tiles past the " + count(tiles) + " of " +
                    std::to_string(mesh.tile_resolution) + "² texels given",
                "give tile_resolution² texels per tile, and tiles for every slot that names one");
  }
  const std::size_t detail = static_cast<std::size_t>(std::max(mesh.detail_resolution, 0)) * std::max(mesh.detail_resolution, 0);
  if ((!mesh.detail_normal.empty() && mesh.detail_normal.size() != 3 * detail) ||
      (!mesh.detail_height.empty() && mesh.detail_height.size() != detail) ||
      (!mesh.face_detail_repeat.empty() && mesh.face_detail_repeat.size() != 2 * slots) ||
      (!mesh.face_relief.empty() && mesh.face_relief.size() != slots) ||
      (!mesh.instance_replicas.empty() && mesh.instance_replicas.size() != corners / 3)) {
    throw Error("embedded mesh: the detail maps, repeats, relief or replica counts do not match its sizes",
                "give detail_resolution² texels per map (3 channels for normals), 2 repeats and 1 relief per slot, "
                "1 replica count per instance (or leave each empty)");
  }
  if (mesh.sphere_barycentric.size() != 4 * mesh.sphere_tet.size() || mesh.sphere_radius.size() != mesh.sphere_tet.size()) {
    throw Error("embedded mesh: " + count(mesh.sphere_tet.size()) + " spheres with " + count(mesh.sphere_barycentric.size()) +
                    " barycentric values and " + count(mesh.sphere_radius.size()) + " radii",
                "give 4 barycentric values and 1 radius per sphere");
  }
}

/// The instances' corners, identical ones stored once and indexed (a render vertex is a
/// corner of every instance of its triangles in the same tet, so each (vertex, tet) is
/// shaded once). Returns the bytes sent.
std::size_t upload_instances(const EmbeddedMesh& mesh, EmbeddedBody& body) {
  const std::size_t corners = mesh.tet.size();
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
  body.corners = static_cast<GLsizei>(corners);
  const GLuint vao = body.vertex_array.get();
  glNamedBufferStorage(body.vertices.get(), static_cast<GLsizeiptr>(std::max<std::size_t>(1, data.size()) * sizeof(EmbeddedCorner)),
                       data.empty() ? nullptr : data.data(), 0);
  glNamedBufferStorage(body.indices.get(), static_cast<GLsizeiptr>(std::max<std::size_t>(1, corners) * sizeof(std::uint32_t)),
                       indices.empty() ? nullptr : indices.data(), 0);
  glVertexArrayVertexBuffer(vao, 0, body.vertices.get(), 0, sizeof(EmbeddedCorner));
  glVertexArrayElementBuffer(vao, body.indices.get());
  set_vertex_attribute(vao, 0, 4, GL_FLOAT, offsetof(EmbeddedCorner, barycentric), false);
  set_vertex_attribute(vao, 1, 1, GL_UNSIGNED_INT, offsetof(EmbeddedCorner, tet), true);
  set_vertex_attribute(vao, 2, 3, GL_FLOAT, offsetof(EmbeddedCorner, rest_normal), false);
  return data.size() * sizeof(EmbeddedCorner) + indices.size() * sizeof(std::uint32_t) +
         body.rest_inverse.upload(mesh.rest_inverse.data(), mesh.rest_inverse.size() * sizeof(float));
}

/// The walls' per-slot tables, tiles and detail maps. Returns the bytes sent.
std::size_t upload_walls(const EmbeddedMesh& mesh, EmbeddedBody& body) {
  std::size_t bytes = mesh.tiles.size() + mesh.detail_normal.size() + mesh.detail_height.size();
  body.face_tile_host = mesh.face_tile;
  bytes += body.face_tile.upload(mesh.face_tile.data(), mesh.face_tile.size() * sizeof(std::int32_t));
  bytes += body.face_uv.upload(mesh.face_uv.data(), mesh.face_uv.size() * sizeof(float));
  body.tiles = upload_tiles(mesh, body.atlas);
  // A tile byte is 127.5 ± 127 × distance / range (bake/walls.cpp).
  body.solid_threshold = (127.5f + 127.0f * kWallErosionTexels / std::max(mesh.tile_range_texels, 1e-3f)) / 255.0f;
  body.detail = upload_detail(mesh.detail_resolution, mesh.detail_normal, 3);
  std::vector<float> repeat = mesh.face_detail_repeat;
  repeat.resize(2 * mesh.face_tile.size(), 1.0f);
  bytes += body.detail_repeat.upload(repeat.data(), repeat.size() * sizeof(float));
  // Relief needs the height map; without one every wall is drawn flat.
  body.height = upload_detail(mesh.detail_resolution, mesh.detail_height, 1);
  body.detail_resolution = mesh.detail_resolution;
  std::vector<float> relief = body.height != 0 ? mesh.face_relief : std::vector<float>{};
  relief.resize(mesh.face_tile.size(), 0.0f);
  return bytes + body.relief.upload(relief.data(), relief.size() * sizeof(float));
}

}  // namespace

std::unique_ptr<EmbeddedBody> upload_embedded(const EmbeddedMesh& mesh, std::size_t& upload_bytes) {
  validate(mesh);
  auto body = std::make_unique<EmbeddedBody>();
  body->color = mesh.color;
  body->interior_color = mesh.interior_color;
  upload_bytes += upload_instances(mesh, *body);  // first: it sets body->corners, which the debug data sizes by
  upload_bytes += upload_walls(mesh, *body);
  upload_bytes += upload_debug_data(mesh, *body);
  return body;
}

std::size_t upload_pose(EmbeddedBody& body, const BodyPose& pose) {
  std::size_t bytes = body.nodes.upload(pose.positions.data(), pose.positions.size_bytes());
  body.bounds.setEmpty();
  for (std::size_t n = 0; n + 2 < pose.positions.size(); n += 3) {
    const Vec3f x(pose.positions[n], pose.positions[n + 1], pose.positions[n + 2]);
    if (x.allFinite()) body.bounds.extend(x);
  }
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
  return bytes;
}

}  // namespace fissure::render
