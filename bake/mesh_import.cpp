#include "bake/mesh_import.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <assimp/importerdesc.h>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <new>
#include <string_view>
#include <vector>

#include "common/child_probe.h"
#include "common/error.h"
#include "common/input_file.h"
#include "common/log.h"
#include "formats/ply.h"

namespace fissure::bake {
namespace {

/// Removes unused vertices after welding, keeping the first occurrence's attributes.
void weld_positions(SurfaceMesh& mesh) {
  const std::vector<Index> representative = position_representatives(mesh.positions);
  std::vector<Index> remap(mesh.vertex_count(), kInvalidIndex);
  Index kept = 0;
  for (Index v = 0; v < mesh.vertex_count(); ++v) {
    if (representative[v] == v) remap[v] = kept++;
  }
  auto compact = [&](auto& matrix) {
    if (matrix.cols() == 0) return;
    std::remove_reference_t<decltype(matrix)> out(matrix.rows(), kept);
    for (Index v = 0; v < mesh.vertex_count(); ++v) {
      if (remap[v] != kInvalidIndex) out.col(remap[v]) = matrix.col(v);
    }
    matrix = std::move(out);
  };
  compact(mesh.positions);
  compact(mesh.normals);
  compact(mesh.uvs);
  for (Eigen::Index i = 0; i < mesh.triangles.size(); ++i) {
    mesh.triangles.data()[i] = remap[representative[mesh.triangles.data()[i]]];
  }
}

ImportedMesh import_ply(const std::filesystem::path& path, const MeshImportOptions& options) {
  formats::PlyMesh ply = formats::read_ply(path);
  if (ply.mesh.triangle_count() == 0) {
    throw Error(path.string() + ": the file holds no triangles", "export the surface as a triangle or polygon mesh");
  }
  ImportedMesh result{std::move(ply.mesh), 1, ply.skipped_faces};
  if (result.mesh.normals.cols() == 0) log_debug(path.string() + ": no normals; the player will compute them");
  if (options.weld) weld_positions(result.mesh);
  return result;
}

/// Assimp's post-processing trusts what its readers report: a damaged file whose
/// faces do not match the mesh's primitive-type flags aborts in TriangulateProcess
/// (ai_assert numOut != mNumFaces; a truncated OFF face list, found by fuzz/mesh_fuzz),
/// and an index past the vertices reads out of bounds. So every face is checked, and
/// the flags are recomputed from the faces, before post-processing. The scene is the
/// importer's own, which its post-processing steps modify in place too.
void check_faces(const aiScene& scene, const std::string& name) {
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    aiMesh* mesh = scene.mMeshes[m];
    unsigned types = 0;
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices == 0 || face.mIndices == nullptr) {
        throw Error(name + ": face " + std::to_string(f) + " of mesh " + std::to_string(m) + " has no vertices",
                    "the file is damaged or truncated; export it again");
      }
      for (unsigned k = 0; k < face.mNumIndices; ++k) {
        if (face.mIndices[k] >= mesh->mNumVertices) {
          throw Error(name + ": face " + std::to_string(f) + " of mesh " + std::to_string(m) + " refers to vertex " +
                          std::to_string(face.mIndices[k]) + " of " + std::to_string(mesh->mNumVertices),
                      "the file is damaged or truncated; export it again");
        }
      }
      types |= face.mNumIndices == 1   ? aiPrimitiveType_POINT
               : face.mNumIndices == 2 ? aiPrimitiveType_LINE
               : face.mNumIndices == 3 ? aiPrimitiveType_TRIANGLE
                                       : aiPrimitiveType_POLYGON;
    }
    mesh->mPrimitiveTypes = types;
  }
}

/// Reads the file through assimp and post-processes it: the importer's own scene, with
/// every coordinate finite and every face checked.
const aiScene* read_assimp_scene(Assimp::Importer& importer, const std::string& name) {
  // Lines and points cannot be embedded: have assimp drop them after sorting by type.
  // The scene graph is walked by the caller rather than flattened by
  // aiProcess_PreTransformVertices, which would also merge meshes by material and hide
  // how many the file held.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  // No aiProcess_ValidateDataStructure: it refuses OBJ faces of one or two vertices
  // that SortByPType below drops as points and lines (a common exporter habit).
  const aiScene* scene = importer.ReadFile(name, 0);
  if (scene == nullptr) {
    // Assimp turns a failed allocation into an error string; under the probe's memory
    // budget that is the budget running out, which the parent reports as such.
    if (inside_child_probe() && std::string_view(importer.GetErrorString()).find("bad_alloc") != std::string_view::npos) {
      throw std::bad_alloc();
    }
    throw Error(name + ": cannot read the mesh: " + std::string(importer.GetErrorString()),
                "check that the file is complete and in the format its extension says");
  }
  // Check coordinates before post-processing: assimp's vertex joining silently merges
  // a NaN vertex into a neighbour, which would hide the broken input.
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
        throw Error(name + ": vertex " + std::to_string(v) + " of mesh " + std::to_string(m) +
                        " has a non-finite coordinate (NaN or Inf)",
                    "fix the exporter; such a vertex cannot be embedded");
      }
    }
  }
  check_faces(*scene, name);
  scene = importer.ApplyPostProcessing(aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType);
  if (scene == nullptr) throw Error(name + ": post-processing failed: " + std::string(importer.GetErrorString()));
  return scene;
}

/// The reader assimp picks for this file, as assimp names it ("Collada Importer").
std::string assimp_reader_name(const std::filesystem::path& path) {
  const Assimp::Importer importer;
  const std::size_t index = importer.GetImporterIndex(path.extension().string().c_str());
  const aiImporterDesc* info = index == static_cast<std::size_t>(-1) ? nullptr : importer.GetImporterInfo(index);
  return info != nullptr && info->mName != nullptr ? info->mName : "reader for " + path.extension().string();
}

/// What assimp's reader of one file may use in the probe: enough for any sound file
/// (a real 1 MiB OBJ reads in about 50 ms), a bound for a damaged one. Damaged Collada,
/// SMD and NFF files used to make it spin without end, growing ~70 MB/s (issue 46).
ChildProbeLimits assimp_limits(std::uintmax_t file_bytes) {
  const double mib = static_cast<double>(file_bytes) / (1 << 20);
  ChildProbeLimits limits;
  limits.wall_seconds = 4.0 + mib;  // at least 1 MiB/s after a 4 s start
  limits.cpu_seconds = limits.wall_seconds + 2.0;
  limits.memory_bytes = (std::uint64_t{1} << 30) + 64 * static_cast<std::uint64_t>(file_bytes);
  return limits;
}

/// Assimp 5.2's readers and post-processing still crash on some damaged files, after
/// check_faces (a SEGV inside libassimp, found by fuzz/mesh_fuzz in CI), and some hang.
/// Fissure cannot check the bytes of every format assimp reads, so the file is read
/// once in a forked child first, under a time and memory budget; a crash, a hang or a
/// runaway allocation there is an error naming the file and the reader, never a crashed
/// or hung bake. An error there is reported as it is, without reading again. It costs
/// one fork and a second read (docs/robustness.md has the figure).
void require_assimp_survives(const std::filesystem::path& path, std::uintmax_t file_bytes) {
  if (inside_child_probe()) return;
  const std::string name = path.string();
  const ChildProbeOutcome outcome = run_in_child(
      [&] {
        Assimp::Importer importer;
        (void)read_assimp_scene(importer, name);
      },
      assimp_limits(file_bytes));
  if (!outcome.error.empty()) throw Error(outcome.error, outcome.error_hint);
  if (outcome.finished) return;
  const std::string reader = "assimp's " + assimp_reader_name(path);
  const char* convert = "convert it to OBJ or PLY (PLY is read by Fissure's own reader)";
  if (outcome.timed_out || outcome.out_of_memory) {
    throw Error(name + ": " + reader + " gave up on this file: it " + outcome.how,
                std::string("the file is damaged, or too much for that reader; ") + convert);
  }
  throw Error(name + ": " + reader + " crashed on this file: reading it " + outcome.how,
              std::string("the file is damaged, or uses something assimp cannot read; export it again, or ") + convert);
}

/// A file assimp is given: a regular, non-empty file of a format it reads. Returns its size.
std::uintmax_t require_mesh_file(const std::filesystem::path& path) {
  const std::string name = path.string();
  require_regular_input(path);  // a FIFO or /dev/zero would stream without end
  std::error_code ec;
  const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
  if (ec || bytes == 0) throw Error(name + ": the file is empty");
  if (!Assimp::Importer().IsExtensionSupported(path.extension().string())) {
    throw Error(name + ": unknown mesh format '" + path.extension().string() + "'",
                "use a format assimp reads: .obj, .ply, .stl, .gltf, .glb, .fbx, .dae, .off …");
  }
  return bytes;
}

/// One placement of a mesh in the scene graph: glTF and FBX reuse a mesh in several nodes.
struct Instance {
  const aiMesh* mesh;
  aiMatrix4x4 transform;
};

/// Every triangle mesh the scene graph places, with its accumulated node transform.
/// The graph is checked as it is walked: on some damaged files assimp's RAW reader
/// leaves a null in a node's list of children (found by scripts/fuzz-cli.py, issue 46),
/// which crashed the bake here, after the probe had read the file without harm.
std::vector<Instance> collect_instances(const aiScene& scene, const std::string& name) {
  std::vector<Instance> instances;
  const auto collect = [&](const auto& self, const aiNode* node, const aiMatrix4x4& parent) -> void {
    const aiMatrix4x4 transform = parent * node->mTransformation;
    for (unsigned i = 0; i < node->mNumMeshes; ++i) {
      const unsigned index = node->mMeshes[i];
      if (index >= scene.mNumMeshes || scene.mMeshes[index] == nullptr) {
        throw Error(name + ": the scene graph refers to mesh " + std::to_string(index) + " of " +
                        std::to_string(scene.mNumMeshes),
                    "the file is damaged; export it again, or convert it to OBJ or PLY");
      }
      const aiMesh* mesh = scene.mMeshes[index];
      if ((mesh->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) != 0) instances.push_back({mesh, transform});
    }
    for (unsigned c = 0; c < node->mNumChildren; ++c) {
      if (node->mChildren[c] != nullptr) self(self, node->mChildren[c], transform);
    }
  };
  if (scene.mRootNode != nullptr) collect(collect, scene.mRootNode, aiMatrix4x4());
  return instances;
}

/// Sizes the merged mesh for all instances: attributes only where every mesh has them.
void allocate_merged(const std::vector<Instance>& instances, const std::string& name, SurfaceMesh& out) {
  std::size_t vertex_total = 0, triangle_total = 0;
  bool all_normals = true, all_uvs = true;
  for (const Instance& instance : instances) {
    vertex_total += instance.mesh->mNumVertices;
    triangle_total += instance.mesh->mNumFaces;
    all_normals = all_normals && instance.mesh->HasNormals();
    all_uvs = all_uvs && instance.mesh->HasTextureCoords(0);
  }
  if (triangle_total == 0) {
    throw Error(name + ": the file holds no triangles", "export the surface as a triangle or polygon mesh");
  }
  if (vertex_total >= kInvalidIndex || triangle_total >= kInvalidIndex) {
    throw Error(name + ": more than 2^32-2 vertices or triangles");
  }
  out.positions.resize(3, static_cast<Eigen::Index>(vertex_total));
  out.triangles.resize(3, static_cast<Eigen::Index>(triangle_total));
  if (all_normals) out.normals.resize(3, static_cast<Eigen::Index>(vertex_total));
  if (all_uvs) out.uvs.resize(2, static_cast<Eigen::Index>(vertex_total));
  if (!all_normals) log_debug(name + ": no normals on every mesh; the player will compute them");
}

/// Copies instance `m`'s vertices, transformed, into `out` from `vertex_base` on.
void copy_vertices(const Instance& instance, std::size_t m, Index vertex_base, const std::string& name, SurfaceMesh& out) {
  const aiMesh* mesh = instance.mesh;
  const aiMatrix3x3 normal_transform = aiMatrix3x3(aiMatrix4x4(instance.transform).Inverse().Transpose());
  for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
    const aiVector3D p = instance.transform * mesh->mVertices[v];
    const Vec3 position(p.x, p.y, p.z);
    if (!position.allFinite()) {
      throw Error(name + ": vertex " + std::to_string(v) + " of mesh " + std::to_string(m) +
                  " overflows when its node transform is applied");
    }
    out.positions.col(vertex_base + v) = position;
    if (out.normals.cols() > 0) {
      aiVector3D n = normal_transform * mesh->mNormals[v];
      n.NormalizeSafe();
      out.normals.col(vertex_base + v) = Vec3(n.x, n.y, n.z);
    }
    if (out.uvs.cols() > 0) {
      const aiVector3D& uv = mesh->mTextureCoords[0][v];
      out.uvs.col(vertex_base + v) = Vec2(uv.x, uv.y);
    }
  }
}

/// Appends instance `m`'s triangles to `out` from `triangle` on; returns the next free
/// column. Faces that are not triangles are counted in `skipped`.
Index copy_triangles(const Instance& instance, std::size_t m, Index vertex_base, Index triangle, const std::string& name,
                     SurfaceMesh& out, std::size_t& skipped) {
  const aiMesh* mesh = instance.mesh;
  // A mirroring transform (negative scale, common in glTF and FBX) turns triangles
  // inside out; swap two corners so they still face outward.
  const bool mirrored = instance.transform.Determinant() < 0;
  for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
    const aiFace& face = mesh->mFaces[f];
    if (face.mNumIndices != 3) {
      ++skipped;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      if (face.mIndices[k] >= mesh->mNumVertices) {
        throw Error(name + ": face " + std::to_string(f) + " of mesh " + std::to_string(m) + " references vertex " +
                        std::to_string(face.mIndices[k]) + " but the mesh has " + std::to_string(mesh->mNumVertices),
                    "the file is corrupt; re-export it");
      }
      out.triangles(k, triangle) = vertex_base + face.mIndices[k];
    }
    if (mirrored) std::swap(out.triangles(1, triangle), out.triangles(2, triangle));
    ++triangle;
  }
  return triangle;
}

ImportedMesh import_assimp(const std::filesystem::path& path, std::uintmax_t file_bytes, const MeshImportOptions& options) {
  const std::string name = path.string();
  require_assimp_survives(path, file_bytes);
  Assimp::Importer importer;
  const aiScene* scene = read_assimp_scene(importer, name);
  const std::vector<Instance> instances = collect_instances(*scene, name);

  ImportedMesh result;
  result.source_meshes = instances.size();
  SurfaceMesh& out = result.mesh;
  allocate_merged(instances, name, out);
  Index vertex_base = 0;
  Index triangle = 0;
  for (std::size_t m = 0; m < instances.size(); ++m) {
    copy_vertices(instances[m], m, vertex_base, name, out);
    triangle = copy_triangles(instances[m], m, vertex_base, triangle, name, out, result.skipped_primitives);
    vertex_base += instances[m].mesh->mNumVertices;
  }
  out.triangles.conservativeResize(3, triangle);
  if (out.normals.cols() > 0 && !out.normals.allFinite()) out.normals.resize(3, 0);

  if (result.source_meshes > 1) {
    log_info(name + ": merged " + std::to_string(result.source_meshes) + " meshes into one render mesh");
  }
  if (options.weld) weld_positions(out);
  return result;
}

}  // namespace

ImportedMesh import_render_mesh(const std::filesystem::path& path, const MeshImportOptions& options) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return std::tolower(c); });
  if (extension == ".ply") {
    require_regular_input(path);
    std::error_code ec;
    if (std::filesystem::file_size(path, ec) == 0) throw Error(path.string() + ": the file is empty");
    return import_ply(path, options);  // not through assimp: see formats/ply.h
  }
  return import_assimp(path, require_mesh_file(path), options);
}

}  // namespace fissure::bake
