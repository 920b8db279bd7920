#pragma once
/// Budgets a project sets on its bundles (`fissure-bake verify --max-…`): what a bundle
/// may cost at run time and on disk. Each budget that is set becomes one more check in
/// verify's report, failing with the measured value against the limit.

#include <cstdint>
#include <optional>
#include <vector>

#include "formats/bundle.h"
#include "formats/bundle_checks.h"

namespace fissure::formats {

struct BundleBudgets {
  std::optional<double> instances_per_triangle;  ///< replication: draw cost per render triangle
  std::optional<std::uint64_t> file_bytes;       ///< the bundle on disk
  std::optional<std::uint64_t> spheres;          ///< collision spheres: contact cost
  std::optional<std::uint64_t> tiles;            ///< wall tiles: texture memory
  [[nodiscard]] bool any() const { return instances_per_triangle || file_bytes || spheres || tiles; }
};

/// One check per budget set, named "budget:<what>"; none when no budget is set.
std::vector<VerifyCheck> check_budgets(const Bundle& bundle, std::uint64_t file_bytes, const BundleBudgets& budgets);

}  // namespace fissure::formats
