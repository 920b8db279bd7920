#pragma once
/// The renderer (thesis chapter V; docs/architecture.md, "The sim/render boundary"):
/// draws the embedded render meshes from the cage's motion, plain meshes (obstacles,
/// projectiles), and the ground, sky and shadows (ground.h), into its own framebuffer,
/// and reads the image back. GL-free interface: the app hands it float and integer spans
/// (player/app/render_frame.h); it never sees the physics.
///
/// Embedded mesh (V.A): each (triangle, tet) instance is three vertices holding their
/// barycentric coordinates in that tet, in a static buffer uploaded once. Per frame only
/// the node positions go up (and the tet→node table, walls and fragments when fracture
/// changed them); the vertex shader places each vertex from its tet's nodes, the
/// fragment shader discards what lies outside the tet, half a pixel of slack aside (so
/// an instance duplicated in several tets shows each tet's part once), and normals follow the
/// deformation through the cofactor of F (F⁻ᵀ det F), F computed in the shader from the
/// tet's nodes and its static rest inverse: exact for any affine map, shear and stretch
/// included, where the rotation alone is not.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace fissure::render {

using Vec3f = Eigen::Vector3f;
using Mat4f = Eigen::Matrix4f;

struct Camera {
  Vec3f eye = Vec3f(2, -2, 1.5);
  Vec3f target = Vec3f::Zero();
  Vec3f up = Vec3f::UnitZ();
  float fov_y_degrees = 35;
  float near_plane = 0.01f, far_plane = 100.0f;
};

/// A camera looking along `direction` at `box` from far enough to see all of it, `up`
/// (the world's up) at the top of the image.
Camera frame_box(const Eigen::AlignedBox3f& box, const Vec3f& direction, const Vec3f& up, float fov_y_degrees,
                 float aspect);

struct Light {
  Vec3f towards = Vec3f(0.4f, -0.5f, 1.0f).normalized();  ///< unit, from the scene to the light
  float ambient = 0.25f;
};

/// The ground plane normal·x = offset, drawn to the horizon with a faint checker of
/// `cell` metres, receiving the shadows of bodies and plain meshes.
struct Ground {
  Vec3f normal = Vec3f::UnitZ();
  float offset = 0.0f;
  float cell = 0.1f;  ///< checker cell side [m]
  Vec3f color = Vec3f(0.60f, 0.58f, 0.54f);
};

/// The background: the horizon's colour at and below the horizon (the ground fades into
/// it), turning to the zenith's overhead; both the same: a flat background.
struct Sky {
  Vec3f horizon = Vec3f(0.93f, 0.94f, 0.96f);
  Vec3f zenith = Vec3f(0.93f, 0.94f, 0.96f);
};

/// What a tet face shows when fracture opens it (thesis V.B), one per (tet, local face).
inline constexpr std::int32_t kWallWhole = -1;  ///< the face lies inside the solid: drawn whole
inline constexpr std::int32_t kWallNone = -2;   ///< the face lies outside the solid: never drawn

/// One body's embedded mesh, static: three corners per instance; and its walls.
struct EmbeddedMesh {
  std::vector<float> barycentric;      ///< 4 per corner: the corner in its tet's barycentric coordinates
  std::vector<std::uint32_t> tet;      ///< 1 per corner
  std::vector<float> rest_normal;      ///< 3 per corner: the vertex normal at rest, in world axes
  /// 9 per tet: the inverse of its rest edge matrix [x1−x0, x2−x0, x3−x0], column-major,
  /// for F = Dx Du⁻¹ (a split changes which nodes a tet has, never its rest shape).
  std::vector<float> rest_inverse;
  Vec3f color = Vec3f(0.78f, 0.74f, 0.68f);
  /// Walls: per (tet, local face k) slot 4t + k, the face's tile (≥ 0: its signed-distance
  /// tile decides which part is solid), kWallWhole or kWallNone; and per slot and face
  /// corner j (local node kTetFaceNodes[k][j]) the corner's (u, v) in the tile.
  std::vector<std::int32_t> face_tile;
  std::vector<float> face_uv;          ///< 6 per slot
  int tile_resolution = 0;             ///< texels per tile side
  float tile_range_texels = 4.0f;      ///< the distance a tile's 0 and 255 stand for, in texels (Walls::sdf_range_texels)
  std::vector<std::uint8_t> tiles;     ///< tiles × resolution²: ≥ 128 inside the solid (the bake's SDF)
  Vec3f interior_color = Vec3f(0.80f, 0.45f, 0.36f);
  /// The shared detail material of the walls: a tileable tangent-space normal map
  /// (detail_resolution² × 3, 127.5 = 0), and per slot how many times it repeats along
  /// the tile's u and v axes (so the grain has one size on every face). Empty: flat walls.
  int detail_resolution = 0;
  std::vector<std::uint8_t> detail_normal;
  std::vector<float> face_detail_repeat;  ///< 2 per slot
  /// Tessellated relief (thesis V.C): the detail's tileable height map (detail_resolution²,
  /// 127.5 = the face's plane), and per slot the most it may raise or sink the face [m]
  /// (0: drawn flat; at most the bake's clearance, so relief stays inside the solid).
  /// Empty: no relief.
  std::vector<std::uint8_t> detail_height;
  std::vector<float> face_relief;
  /// For the replication view: per instance, how many instances its triangle has (in how
  /// many tets it is drawn). Empty: every triangle counts as one.
  std::vector<std::uint32_t> instance_replicas;
  /// For the collision-sphere view: the physics' spheres, each a tet, its centre's 4
  /// barycentric coordinates in it and its radius [m]. Empty: the view shows none.
  std::vector<std::uint32_t> sphere_tet;
  std::vector<float> sphere_barycentric;
  std::vector<float> sphere_radius;
  Vec3f sphere_color = Vec3f(0.30f, 0.60f, 0.80f);
};

/// The replication view's colour of a triangle drawn in `replicas` tets (thesis
/// Fig. 24): 1 grey-green, 2 yellow, 3 orange, 4 red, 5 or more purple.
Vec3f replication_color(std::uint32_t replicas);

/// One body's cage as it is this frame.
struct BodyPose {
  std::span<const float> positions;      ///< 3 per node [m]
  std::span<const std::uint32_t> tets;   ///< 4 per tet
  /// Per (tet, local face) slot: 2 where fracture opened the face (sim::FaceState::Fractured).
  std::span<const std::uint8_t> faces;
  /// Per tet, its fragment (connected piece); for the fragment view. May be empty.
  std::span<const std::uint32_t> fragment;
  std::uint64_t topology_version = 0;    ///< `tets` and `faces` are uploaded only when this changes
};

/// A plain indexed triangle mesh in its own frame, placed by `transform`.
struct PlainMesh {
  std::vector<float> positions;          ///< 3 per vertex
  std::vector<float> normals;            ///< 3 per vertex
  std::vector<std::uint32_t> triangles;  ///< 3 per triangle
  Vec3f color = Vec3f(0.5f, 0.5f, 0.5f);
};

/// What the last render() cost.
struct RenderStats {
  std::size_t upload_bytes = 0;  ///< sent to the GPU since the previous render
  double draw_ms = 0;            ///< drawing and reading the image back (CPU wall clock, GPU work included)
};

class Renderer {
 public:
  /// Needs a current GL 4.5 core context (context.h). Throws fissure::Error when a
  /// shader does not build or the framebuffer cannot be made.
  Renderer(int width, int height);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  [[nodiscard]] int width() const;
  [[nodiscard]] int height() const;

  /// Adds a body; returns its handle. Its pose must be set before it is drawn.
  std::size_t add_body(const EmbeddedMesh& mesh);
  void set_pose(std::size_t body, const BodyPose& pose);
  /// Adds a plain mesh (identity transform, visible); returns its handle.
  std::size_t add_plain(const PlainMesh& mesh);
  void set_transform(std::size_t plain, const Mat4f& transform);
  void set_visible(std::size_t plain, bool visible);
  void set_body_visible(std::size_t body, bool visible);
  /// Whether the walls fracture opened are drawn (on by default), and whether they are
  /// normal-mapped with the detail material (on by default).
  void set_walls_visible(bool visible);
  void set_normal_mapping(bool enabled);
  /// Tessellated relief on the walls inside the solid (thesis V.C): each wall is split
  /// inside (its edges stay whole) into about one segment per `pixels_per_segment` of its
  /// longest edge on screen, at most `max_level`
  /// (clamped to the GPU's limit); `max_level` ≤ 1 turns it off (walls flat, normal
  /// mapping alone). Off by default.
  void set_tessellation(float max_level, float pixels_per_segment = 8.0f);
  /// Debug view: each fragment (connected piece) of a body in its own colour.
  void set_fragment_colors(bool enabled);
  /// Debug view: the cages' edges over the image.
  void set_cage_visible(bool visible);
  /// Debug view: each body's collision spheres where the physics has them, drawn in
  /// place of its surface and walls (thesis Fig. 20).
  void set_spheres_visible(bool visible);
  /// Debug view: each triangle coloured by how many tets it is drawn in (thesis Fig. 24;
  /// replication_color()).
  void set_replication_colors(bool enabled);

  void set_camera(const Camera& camera);
  void set_light(const Light& light);
  /// A flat background (set_sky with both colours `color`).
  void set_background(const Vec3f& color);
  void set_sky(const Sky& sky);
  /// The ground (none by default), and whether bodies and plain meshes cast shadows on
  /// it (on by default; a shadow map fitted to them each frame, sized to their size on
  /// screen).
  void set_ground(const Ground& ground);
  void set_shadows(bool enabled);

  /// Draws everything and reads the image back into `rgba`: width × height × 4 bytes,
  /// top row first.
  void render(std::vector<std::uint8_t>& rgba);
  /// Draws everything into the renderer's framebuffer without reading it back (a window
  /// shows it with present()); read() reads the last drawing.
  void draw();
  void read(std::vector<std::uint8_t>& rgba) const;
  /// Copies the last drawing to the current context's default framebuffer (a window's),
  /// `width` × `height` pixels, and leaves that framebuffer bound for overlays (a UI).
  void present(int width, int height) const;
  /// A new image size (a resized window); throws fissure::Error as the constructor does.
  void resize(int width, int height);
  [[nodiscard]] const RenderStats& last_stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace fissure::render
