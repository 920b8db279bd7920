#pragma once
/// What `fissure-bake inspect` prints: counts, sizes and a per-group summary of a
/// bundle, as text for people or JSON for pipelines.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "formats/bundle.h"

namespace fissure::formats {

struct DatasetSummary {
  std::string path;                  ///< e.g. "/render/positions"
  std::vector<std::uint64_t> shape;
  std::uint64_t stored_bytes = 0;    ///< on disk, after compression
};

struct BundleSummary {
  std::string file;
  std::uint64_t file_bytes = 0;
  Bundle bundle;
  std::vector<DatasetSummary> datasets;
  std::vector<std::string> stages;   ///< top-level stage groups present, e.g. "embedding"
};

/// Reads (and so validates) the bundle and collects dataset sizes. Throws fissure::Error.
BundleSummary summarize_bundle(const std::filesystem::path& path);

std::string summary_text(const BundleSummary& summary);
std::string summary_json(const BundleSummary& summary);

}  // namespace fissure::formats
