#include "bake/replication.h"

#include <cstdio>
#include <filesystem>

#include "bake/exact_embedding.h"
#include "common/json_writer.h"
#include "formats/bundle_checks.h"
#include "formats/cage_io.h"

namespace fissure::bake {

std::vector<ReplicationRow> replication_study(const std::string& mesh_path, const std::vector<std::string>& cages,
                                              const MeshImportOptions& import) {
  const ImportedMesh imported = import_render_mesh(mesh_path, import);
  std::vector<ReplicationRow> rows;
  for (const std::string& cage_path : cages) {
    const formats::CageFile cage = formats::read_cage(cage_path);
    const TriangleTetPairs pairs = assign_triangles(imported.mesh, cage.mesh, build_cage_faces(cage.mesh, cage_path));
    formats::Embedding embedding;
    embedding.instance_triangle = pairs.triangle;
    ReplicationRow row;
    row.cage = std::filesystem::path(cage_path).filename().string();
    row.tets = cage.mesh.tet_count();
    row.counts = formats::replication_histogram(imported.mesh.triangle_count(), embedding);
    row.instances = pairs.triangle.size();
    rows.push_back(std::move(row));
  }
  return rows;
}

std::string replication_table(const std::vector<ReplicationRow>& rows) {
  std::string out = "| cage | tets | 0x | 1x | 2x | 3x | 4x | 5x | 6x | 7x | 8+x | total | total/triangles |\n";
  out += "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  char buffer[64];
  for (const ReplicationRow& row : rows) {
    std::size_t triangles = 0;
    for (const auto c : row.counts) triangles += c;
    out += "| " + row.cage + " | " + std::to_string(row.tets) + " |";
    for (const auto c : row.counts) out += " " + std::to_string(c) + " |";
    std::snprintf(buffer, sizeof buffer, " %zu | %.3f |\n", row.instances,
                  triangles ? static_cast<double>(row.instances) / static_cast<double>(triangles) : 0.0);
    out += buffer;
  }
  return out;
}

std::string replication_json(const std::vector<ReplicationRow>& rows) {
  JsonWriter j;
  j.begin_array();
  for (const ReplicationRow& row : rows) {
    j.begin_object().key("cage").value(row.cage).key("tets").value(static_cast<std::uint64_t>(row.tets));
    j.key("counts").begin_array();
    for (const auto c : row.counts) j.value(static_cast<std::uint64_t>(c));
    j.end_array().key("instances").value(static_cast<std::uint64_t>(row.instances)).end_object();
  }
  j.end_array();
  return j.str() + "\n";
}

}  // namespace fissure::bake
