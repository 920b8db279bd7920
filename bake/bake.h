#pragma once
/// The bake pipeline: render mesh + cage → bundle (stage 1: embedding).

#include <cstddef>
#include <filesystem>
#include <string>

#include "bake/auto_cage.h"
#include "bake/collision_proxies.h"
#include "bake/mesh_import.h"
#include "bake/walls.h"
#include "formats/bundle.h"

namespace fissure::bake {

inline constexpr const char* kGeneratorName = "fissure-bake";

struct BakeOptions {
  MeshImportOptions import;
  /// Barill's β for the winding-number tree (see winding_number.h).
  double winding_accuracy = 3.0;
  /// A triangle counts as covered when its instances' clipped areas sum to its area
  /// within this relative tolerance; otherwise the cage does not cover the mesh.
  double coverage_tolerance = 1e-9;

  /// Optional stages (the embedding always runs): a scene without fracture needs no
  /// walls, one without collisions no spheres (`--only` / `--skip`).
  bool walls = true;
  bool collision = true;
  WallOptions wall;
  SphereOptions spheres;
  /// An automatic cage made from the mesh (`--tets N`) instead of a cage file.
  AutoCageOptions cage;

  /// The options that shape the bundle's content, as a JSON object (stored in it).
  [[nodiscard]] std::string to_json() const;
};

/// What happened during a bake, for logs, benchmarks and tests.
struct BakeStats {
  double import_s = 0, faces_s = 0, assign_s = 0, classify_s = 0, contours_s = 0, coverage_s = 0;
  double regions_s = 0, walls_s = 0, collision_s = 0;
  CollisionStats collision;
  std::size_t inconsistent_faces = 0;
  std::size_t candidates = 0;
  std::size_t degenerate_triangles = 0;
  std::size_t coplanar_pairs = 0;
  std::size_t boundary_edges = 0, boundary_loops = 0, nonmanifold_edges = 0;
  std::size_t repeated_triangles = 0;  ///< dropped copies (bake/repeated_triangles.h)
  std::size_t flipped_triangles = 0;   ///< by the orientation repair (bake/surface_orientation.h)
  std::size_t self_intersections = 0;  ///< crossing triangle pairs (bake/self_intersections.h)
};

/// Embeds `mesh` in `cage` (already validated and positively oriented). The bundle's
/// render mesh is `mesh` with its triangles oriented consistently (warnings say what
/// was flipped).
/// Throws fissure::Error if the cage does not cover the mesh; `mesh_name` and
/// `cage_name` name the inputs in that message.
formats::Bundle embed(const SurfaceMesh& mesh, const TetMesh& cage, const BakeOptions& options,
                      const std::string& mesh_name, const std::string& cage_name, BakeStats* stats = nullptr);

/// Reads both inputs, embeds, records input hashes and options, and returns the bundle.
formats::Bundle bake_files(const std::filesystem::path& mesh_path, const std::filesystem::path& cage_path,
                           const BakeOptions& options, BakeStats* stats = nullptr);

/// Reads the mesh, makes its automatic cage (options.cage), embeds, and records the
/// mesh's hash and the options, the cage's method, count and version among them.
formats::Bundle bake_with_auto_cage(const std::filesystem::path& mesh_path, const BakeOptions& options,
                                    BakeStats* stats = nullptr);

/// Checks exactly, as the bake does (assign and coverage stages), that `cage` holds
/// every point of `mesh` once. Throws fissure::Error naming both otherwise.
void check_cage_covers(const SurfaceMesh& mesh, const TetMesh& cage, const std::string& mesh_name,
                       const std::string& cage_name);

/// The generator string stored in bundles, e.g. "fissure-bake 0.1.0".
std::string generator_string();

}  // namespace fissure::bake
