#pragma once
/// The replication study of thesis Table II: how many render triangles a cage stores
/// once, twice, … seven times, for several cages of one mesh.

#include <cstddef>
#include <string>
#include <vector>

#include "bake/mesh_import.h"

namespace fissure::bake {

struct ReplicationRow {
  std::string cage;                  ///< file name
  std::size_t tets = 0;
  std::vector<std::size_t> counts;   ///< [k] = triangles stored k times, k = 0…8 (8 = 8 or more)
  std::size_t instances = 0;         ///< Σ k·counts[k]: triangles drawn (thesis "Total")
};

std::vector<ReplicationRow> replication_study(const std::string& mesh, const std::vector<std::string>& cages,
                                              const MeshImportOptions& import);

/// Markdown table: cage, tets, 1×…7×, 8+×, total, total / triangles.
std::string replication_table(const std::vector<ReplicationRow>& rows);
std::string replication_json(const std::vector<ReplicationRow>& rows);

}  // namespace fissure::bake
