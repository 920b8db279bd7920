#pragma once
/// The Fissure bundle: everything the bake computes for one asset, in one HDF5 file.
/// The schema is defined here and only here (docs/bundle-schema.md describes it for
/// h5dump/h5py users); both fissure-bake and fissure-player use these types.
///
/// Versioning: a reader accepts any minor version of its major version (minor
/// versions only add optional groups or datasets) and rejects a newer major version.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/surface_mesh.h"
#include "common/tet_mesh.h"
#include "common/types.h"

namespace fissure::formats {

inline constexpr const char* kBundleFormatName = "fissure-bundle";
inline constexpr int kBundleSchemaMajor = 1;
inline constexpr int kBundleSchemaMinor = 0;

/// One input file of the bake, so pipelines can tell when a bundle is stale.
struct BundleInput {
  std::string role;    ///< "mesh", "cage"
  std::string name;    ///< file name(s) as given, without directories
  std::string sha256;  ///< hex digest of the file bytes (for a TetGen pair: .node then .ele)
};

struct BundleMetadata {
  int schema_major = kBundleSchemaMajor;
  int schema_minor = kBundleSchemaMinor;
  std::string generator;     ///< e.g. "fissure-bake 0.1.0"
  std::string units = "m";   ///< length unit of every position in the file
  std::string bake_options;  ///< JSON object of the options that shaped the content
  std::vector<BundleInput> inputs;
};

/// How a tet relates to the solid the surface bounds.
enum class TetClass : std::uint8_t {
  Outside = 0,   ///< no surface inside, and outside the solid: never drawn, no mass
  Inside = 1,    ///< no surface inside, and inside the solid: all walls are interior
  Crossing = 2,  ///< has instances: the surface passes through or touches it (closed-set contact)
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

  [[nodiscard]] std::size_t instance_count() const { return instance_triangle.size(); }
  [[nodiscard]] std::size_t segment_count() const { return contour_triangle.size(); }
};

struct Bundle {
  BundleMetadata metadata;
  SurfaceMesh render;
  TetMesh cage;
  CageFaces faces;
  Embedding embedding;
};

/// Writes atomically: a temporary file beside `path`, renamed over it only when
/// complete, so a reader never sees a half-written bundle. Throws fissure::Error.
void write_bundle(const std::filesystem::path& path, const Bundle& bundle);

/// Reads and validates shapes, index ranges and the schema version.
/// Throws fissure::Error naming the file and the offending dataset.
Bundle read_bundle(const std::filesystem::path& path);

}  // namespace fissure::formats
