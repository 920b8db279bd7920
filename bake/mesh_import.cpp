#include "bake/mesh_import.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <vector>

#include "common/child_probe.h"
#include "common/error.h"
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

/// Assimp 5.2's readers and post-processing still crash on some damaged files, after
/// check_faces: a SEGV inside libassimp, found by fuzz/mesh_fuzz in CI. Fissure cannot
/// check the bytes of every format assimp reads, so the file is read once in a forked
/// child first; a crash there is an error naming the file, never a crashed bake. It
/// costs one fork and a second read (docs/robustness.md has the figure).
void require_assimp_survives(const std::string& name) {
  if (inside_child_probe()) return;
  const ChildProbeOutcome outcome = run_in_child([&] {
    Assimp::Importer importer;
    (void)read_assimp_scene(importer, name);
  });
  if (outcome.finished) return;
  throw Error(name + ": the mesh reader (assimp) crashed on this file: reading it " + outcome.how,
              "the file is damaged, or uses something assimp cannot read; export it again, or convert it to .ply "
              "(read by Fissure's own reader)");
}

}  // namespace

ImportedMesh import_render_mesh(const std::filesystem::path& path, const MeshImportOptions& options) {
  const std::string name = path.string();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(name + ": file not found");
  if (std::filesystem::is_directory(path, ec)) throw Error(name + ": is a directory, not a mesh file");
  if (std::filesystem::file_size(path, ec) == 0) throw Error(name + ": the file is empty");
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return std::tolower(c); });
  if (extension == ".ply") return import_ply(path, options);  // not through assimp: see formats/ply.h

  if (!Assimp::Importer().IsExtensionSupported(path.extension().string())) {
    throw Error(name + ": unknown mesh format '" + path.extension().string() + "'",
                "use a format assimp reads: .obj, .ply, .stl, .gltf, .glb, .fbx, .dae, .off …");
  }
  require_assimp_survives(name);
  Assimp::Importer importer;
  const aiScene* scene = read_assimp_scene(importer, name);

  struct Instance {
    const aiMesh* mesh;
    aiMatrix4x4 transform;
  };
  std::vector<Instance> instances;
  const auto collect = [&](const auto& self, const aiNode* node, const aiMatrix4x4& parent) -> void {
    const aiMatrix4x4 transform = parent * node->mTransformation;
    for (unsigned i = 0; i < node->mNumMeshes; ++i) {
      const aiMesh* mesh = scene->mMeshes[node->mMeshes[i]];
      if ((mesh->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) != 0) instances.push_back({mesh, transform});
    }
    for (unsigned c = 0; c < node->mNumChildren; ++c) self(self, node->mChildren[c], transform);
  };
  if (scene->mRootNode != nullptr) collect(collect, scene->mRootNode, aiMatrix4x4());

  ImportedMesh result;
  result.source_meshes = instances.size();
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

  SurfaceMesh& out = result.mesh;
  out.positions.resize(3, static_cast<Eigen::Index>(vertex_total));
  out.triangles.resize(3, static_cast<Eigen::Index>(triangle_total));
  if (all_normals) out.normals.resize(3, static_cast<Eigen::Index>(vertex_total));
  if (all_uvs) out.uvs.resize(2, static_cast<Eigen::Index>(vertex_total));
  Index vertex_base = 0;
  Index triangle = 0;
  for (std::size_t m = 0; m < instances.size(); ++m) {
    const aiMesh* mesh = instances[m].mesh;
    const aiMatrix4x4& transform = instances[m].transform;
    const aiMatrix3x3 normal_transform = aiMatrix3x3(aiMatrix4x4(transform).Inverse().Transpose());
    // A mirroring transform (negative scale, common in glTF and FBX) turns triangles
    // inside out; swap two corners so they still face outward.
    const bool mirrored = transform.Determinant() < 0;
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D p = transform * mesh->mVertices[v];
      const Vec3 position(p.x, p.y, p.z);
      if (!position.allFinite()) {
        throw Error(name + ": vertex " + std::to_string(v) + " of mesh " + std::to_string(m) +
                        " overflows when its node transform is applied");
      }
      out.positions.col(vertex_base + v) = position;
      if (all_normals) {
        aiVector3D n = normal_transform * mesh->mNormals[v];
        n.NormalizeSafe();
        out.normals.col(vertex_base + v) = Vec3(n.x, n.y, n.z);
      }
      if (all_uvs) {
        const aiVector3D& uv = mesh->mTextureCoords[0][v];
        out.uvs.col(vertex_base + v) = Vec2(uv.x, uv.y);
      }
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) {
        ++result.skipped_primitives;
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
    vertex_base += mesh->mNumVertices;
  }
  out.triangles.conservativeResize(3, triangle);
  if (out.normals.cols() > 0 && !out.normals.allFinite()) out.normals.resize(3, 0);

  if (result.source_meshes > 1) {
    log_info(name + ": merged " + std::to_string(result.source_meshes) + " meshes into one render mesh");
  }
  if (!all_normals) log_debug(name + ": no normals on every mesh; the player will compute them");
  if (options.weld) weld_positions(out);
  return result;
}

}  // namespace fissure::bake
