#pragma once
/// SHA-256 of input files, recorded in the bundle so pipelines can tell when a
/// bundle is stale.

#include <filesystem>
#include <string>
#include <vector>

namespace fissure::bake {

/// Lowercase hex SHA-256 of the concatenated bytes of `files` (in order).
/// Throws fissure::Error if a file cannot be read.
std::string sha256_hex(const std::vector<std::filesystem::path>& files);

}  // namespace fissure::bake
