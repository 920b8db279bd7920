#pragma once
/// The Fissure bundle: everything the bake computes for one asset, in one HDF5 file.
/// The schema is defined here and only here (docs/bundle-schema.md describes it for
/// h5dump/h5py users); both fissure-bake and fissure-player use these types.
///
/// Versioning: a reader accepts any minor version of its major version (minor
/// versions only add optional groups or datasets) and rejects a newer major version.

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "common/surface_mesh.h"
#include "common/tet_mesh.h"
#include "common/types.h"

namespace fissure::formats {

inline constexpr const char* kBundleFormatName = "fissure-bundle";
inline constexpr int kBundleSchemaMajor = 1;
/// 1.1 added walls/face_clearance; 1.2 added /inputs/<role>@path (for `fissure-bake
/// status`) and /embedding@surface_self_intersections.
inline constexpr int kBundleSchemaMinor = 2;

/// One input file of the bake, so pipelines can tell when a bundle is stale.
struct BundleInput {
  std::string role;    ///< "mesh", "cage"
  std::string name;    ///< file name(s) as given, without directories
  std::string sha256;  ///< hex digest of the file bytes (for a TetGen pair: .node then .ele)
  /// Where the bake read it, relative to the bundle's folder, '/'-separated (a TetGen
  /// pair: the .node); empty when unknown (schema < 1.2, or written by a library call).
  std::string path;
};

struct BundleMetadata {
  int schema_major = kBundleSchemaMajor;
  int schema_minor = kBundleSchemaMinor;
  std::string generator;     ///< e.g. "fissure-bake 0.1.0"
  std::string units = "m";   ///< length unit of every position in the file
  std::string bake_options;  ///< JSON object of the options that shaped the content
  std::vector<BundleInput> inputs;
};

/// Where a contour end point lies on its face: 0, 1, 2 = on edge k (from face node k
/// to node k+1, strictly between them), 3, 4, 5 = at face node k−3, or interior.
inline constexpr std::uint8_t kContourInterior = 255;

/// How a tet relates to the solid the surface bounds.
enum class TetClass : std::uint8_t {
  Outside = 0,   ///< no surface inside, and outside the solid: never drawn, no mass
  Inside = 1,    ///< no surface inside, and inside the solid: all walls are interior
  Crossing = 2,  ///< has instances: the surface passes through or touches it (closed-set contact)
};

/// How a cage face relates to the solid: what the renderer draws on it when fracture
/// exposes it (thesis III.C, V.B).
enum class FaceClass : std::uint8_t {
  Outside = 0,     ///< no surface crosses it and it is outside the solid: never drawn
  Inside = 1,      ///< no surface crosses it and it is inside the solid: shared interior material
  Crossing = 2,    ///< the surface cuts it: has a baked tile
  Degenerate = 3,  ///< the surface lies in its plane (aligned with the cage): no exact region, no tile
};

/// Result of the embedding stage (thesis III.A–B, plus the exact contours of III.C).
struct Embedding {
  /// One instance per (render triangle, tet) pair whose closed sets intersect,
  /// sorted by triangle then tet.
  std::vector<TriangleIndex> instance_triangle;
  std::vector<TetIndex> instance_tet;
  /// 4×3 per instance, column j = barycentric coordinates of the triangle's vertex j
  /// with respect to the tet's nodes (each column sums to 1).
  std::vector<Eigen::Matrix<double, 4, 3>> instance_barycentric;

  std::vector<double> node_winding;   ///< #N generalized winding number of each cage node
  std::vector<std::uint8_t> node_inside;  ///< #N 1 if node_winding >= 0.5
  std::vector<TetClass> tet_class;    ///< #T

  /// Contours: segments where the surface crosses each cage face, grouped by face
  /// (CSR): face f owns segments contour_offsets[f] .. contour_offsets[f+1]-1.
  std::vector<std::uint64_t> contour_offsets;  ///< #faces + 1
  std::vector<Eigen::Matrix<double, 3, 2>> contour_points;  ///< per segment: its two end points [m]
  std::vector<TriangleIndex> contour_triangle;  ///< per segment: the render triangle it comes from
  std::vector<std::array<std::uint8_t, 2>> contour_feature;  ///< per segment end point: edge, node or interior
  /// #faces: 1 where a render triangle lies in the face's plane: the face's inside
  /// region is ambiguous there (see Walls::face_class 3).
  std::vector<std::uint8_t> face_degenerate;
  /// Pairs of render triangles that cross each other, found by the bake (an attribute,
  /// stored only when non-zero). Where pieces overlap, the solid and the tiles count
  /// them once, while the signed enclosed volume and the exact face areas count them
  /// with their winding: verify does not compare those totals.
  std::uint64_t surface_self_intersections = 0;

  [[nodiscard]] std::size_t instance_count() const { return instance_triangle.size(); }
  [[nodiscard]] std::size_t segment_count() const { return contour_triangle.size(); }
};

/// Wall textures (stage "walls", thesis III.C): one tile per cage face the surface
/// cuts. Texel (i, j) of a tile sits at face point n0 + u (n1 − n0) + v (n2 − n0) with
/// u = (i + ½)/res, v = (j + ½)/res and (n0, n1, n2) the face's nodes; only u + v ≤ 1
/// is on the face, the rest of the square continues the fields so bilinear filtering
/// is right up to the face's edges.
struct Walls {
  std::vector<FaceClass> face_class;      ///< #faces (stored as uint8 0–3)
  std::vector<Index> face_tile;           ///< #faces: tile of a crossing face, else kInvalidIndex
  std::vector<double> face_inside_area;   ///< #faces: area of face ∩ solid [m²] (exact geometry, double rounding)
  /// #faces (schema ≥ 1.1; empty when read from 1.0): for a face inside the solid, a lower
  /// bound of the distance from any of its points to the outer surface [m], so relief
  /// displaced that far from it stays inside (thesis V.C); 0 for every other class.
  std::vector<double> face_clearance;
  std::uint32_t resolution = 0;           ///< texels per tile side
  double sdf_range_texels = 0;            ///< signed distance saturates at ± this many texels
  /// tiles × res × res (row j, column i): 128 + 127·d/range for inside texels, 127 + 128·d/range
  /// outside (d = signed distance to the contour in texels, clamped): ≥ 128 ⇔ inside,
  /// exactly, for every texel centre on the face.
  std::vector<std::uint8_t> sdf;
  std::uint32_t depth_resolution = 0;     ///< texels per side of the depth tiles
  double depth_scale = 0;                 ///< metres that 255 stands for
  std::vector<std::uint8_t> depth;        ///< tiles × dres × dres: distance to the outer surface (0 outside)
  std::uint32_t detail_resolution = 0;    ///< side of the shared tileable detail maps
  std::uint64_t detail_seed = 0;
  std::vector<std::uint8_t> detail_height;  ///< dr × dr, tileable
  std::vector<std::uint8_t> detail_normal;  ///< dr × dr × 3, tangent-space normal of detail_height, 128 = 0

  [[nodiscard]] std::size_t tile_count() const {
    return resolution == 0 ? 0 : sdf.size() / (static_cast<std::size_t>(resolution) * resolution);
  }
};

/// Collision proxies and mass properties (stage "collision", thesis III.D.2).
struct Collision {
  double target_radius = 0;                   ///< the radius asked for [m]
  std::vector<TetIndex> sphere_tet;           ///< #S
  std::vector<Vec4> sphere_barycentric;       ///< #S centre, barycentric in its tet
  std::vector<double> sphere_radius;          ///< #S [m]; target / 2^k after k halvings
  /// Reserve spheres (#R, same layout, sorted by tet): each covers a render vertex that
  /// no sphere of the tet holding it reaches (bake/surface_spheres.h, reserve_spheres).
  /// The player holds one back until a split parts its tet from `reserve_cover_tet`,
  /// the tet of the sphere that covers the vertex meanwhile (kInvalidIndex where none
  /// does; player/sim/contacts/stand_in_spheres.h). Empty in bundles baked before them.
  std::vector<TetIndex> reserve_tet;
  std::vector<Vec4> reserve_barycentric;
  std::vector<double> reserve_radius;
  std::vector<TetIndex> reserve_cover_tet;
  std::vector<double> mass_fraction;          ///< #T: volume(tet ∩ solid) / volume(tet)
  std::vector<Vec4> center_of_mass;           ///< #T: centroid of tet ∩ solid, barycentric (the tet's centroid if empty)
  /// Tets next to a degenerate face, whose mass was estimated on a lattice instead
  /// of integrated exactly.
  std::uint64_t sampled_tets = 0;
};

struct Bundle {
  BundleMetadata metadata;
  SurfaceMesh render;
  TetMesh cage;
  CageFaces faces;
  Embedding embedding;
  std::optional<Walls> walls;          ///< present when the walls stage ran
  std::optional<Collision> collision;  ///< present when the collision stage ran
};

/// Writes atomically: a temporary file beside `path`, renamed over it only when
/// complete, so a reader never sees a half-written bundle. Throws fissure::Error.
void write_bundle(const std::filesystem::path& path, const Bundle& bundle);

/// Reads and validates shapes, index ranges and the schema version.
/// Throws fissure::Error naming the file and the offending dataset.
Bundle read_bundle(const std::filesystem::path& path);

}  // namespace fissure::formats
