#include "formats/bundle_budgets.h"

#include <algorithm>
#include <cstdio>
#include <string>

namespace fissure::formats {
namespace {

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g", value);
  return text;
}

VerifyCheck within(const char* name, double measured, double limit, const std::string& unit) {
  const bool passed = measured <= limit;
  return {std::string("budget:") + name, passed,
          number(measured) + unit + (passed ? " within " : " exceeds the budget of ") + number(limit) + unit};
}

}  // namespace

std::vector<VerifyCheck> check_budgets(const Bundle& bundle, std::uint64_t file_bytes, const BundleBudgets& budgets) {
  std::vector<VerifyCheck> checks;
  if (budgets.instances_per_triangle) {
    const double triangles = static_cast<double>(std::max<std::size_t>(bundle.render.triangle_count(), 1));
    checks.push_back(within("instances-per-triangle", static_cast<double>(bundle.embedding.instance_count()) / triangles,
                            *budgets.instances_per_triangle, ""));
  }
  if (budgets.file_bytes) {
    checks.push_back(within("size", static_cast<double>(file_bytes) / (1 << 20),
                            static_cast<double>(*budgets.file_bytes) / (1 << 20), " MiB"));
  }
  if (budgets.spheres) {
    const std::size_t spheres = bundle.collision ? bundle.collision->sphere_tet.size() : 0;
    checks.push_back(within("spheres", static_cast<double>(spheres), static_cast<double>(*budgets.spheres), " spheres"));
  }
  if (budgets.tiles) {
    const std::size_t tiles = bundle.walls ? bundle.walls->tile_count() : 0;
    checks.push_back(within("tiles", static_cast<double>(tiles), static_cast<double>(*budgets.tiles), " tiles"));
  }
  return checks;
}

}  // namespace fissure::formats
