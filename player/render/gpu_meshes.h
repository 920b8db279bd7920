#pragma once
/// The GPU side of what the renderer draws (renderer.cpp): an embedded body's static
/// instances, wall tables, tiles and detail maps, uploaded once, and its pose each
/// frame; a plain mesh's buffers. Internal to player/render; needs a current context.

#include <glad/gl.h>

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Geometry>

#include "player/render/gpu_buffer.h"
#include "player/render/renderer.h"

namespace fissure::render {

/// How the signed-distance tiles are packed: a texture array whose layers each hold a
/// square grid of tiles (a cage of 10k tets has ~6,000 tiles, more than the 2,048
/// layers a GL implementation must offer, and far fewer than a layer of 4096² holds).
struct TileAtlas {
  int resolution = 0, cells = 1, layers = 0;  ///< tile side [texels], tiles per layer side, layers
};

struct EmbeddedBody {
  GlName vertices{GlName::Kind::Buffer};
  GlName indices{GlName::Kind::Buffer};
  GlName vertex_array{GlName::Kind::VertexArray};
  GLsizei corners = 0;
  Vec3f color, interior_color;
  Eigen::AlignedBox3f bounds;  ///< of the posed nodes, for the shadow map
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

struct PlainBody {
  GlName vertices{GlName::Kind::Buffer};
  GlName indices{GlName::Kind::Buffer};
  GlName vertex_array{GlName::Kind::VertexArray};
  GLsizei index_count = 0;
  Vec3f color;
  Mat4f transform = Mat4f::Identity();
  bool visible = true;
  std::size_t upload_bytes = 0;  ///< what making it sent to the GPU
  Eigen::AlignedBox3f local_bounds;  ///< of its vertices, before the transform
};

/// Checks every array of `mesh` against the others, then makes its GPU objects (nothing
/// is made when a check fails: it throws fissure::Error naming the array). Adds the bytes
/// sent to `upload_bytes`.
std::unique_ptr<EmbeddedBody> upload_embedded(const EmbeddedMesh& mesh, std::size_t& upload_bytes);

/// Uploads a pose's node positions, and its tets, walls and fragments when its
/// topology version changed. Returns the bytes sent.
std::size_t upload_pose(EmbeddedBody& body, const BodyPose& pose);

/// A plain mesh's buffers, interleaved position and normal per vertex. Throws
/// fissure::Error before making anything when the arrays do not match.
std::unique_ptr<PlainBody> upload_plain(const PlainMesh& mesh);

}  // namespace fissure::render
