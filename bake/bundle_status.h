#pragma once
/// `fissure-bake status`: is a bundle what baking its inputs today would write? A build
/// system or CI job asks this without re-baking: the bundle records its inputs' SHA-256,
/// where they were (relative to the bundle), the options and the bake's version.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "formats/bundle.h"
#include "formats/bundle_checks.h"

namespace fissure::bake {

enum class BundleState {
  UpToDate,      ///< inputs, options and bake version all match
  Stale,         ///< re-baking would change it (or it is missing or unreadable)
  MissingInput,  ///< an input cannot be found, so nothing can be said about it
};

struct BundleStatus {
  std::filesystem::path bundle;
  BundleState state = BundleState::UpToDate;
  std::vector<std::string> reasons;  ///< one line per finding; empty when up to date
};

/// What to compare against instead of what the bundle recorded; unset: the recorded.
struct StatusQuery {
  std::optional<std::filesystem::path> mesh;  ///< the mesh as a bake command would name it
  std::optional<std::filesystem::path> cage;
  std::optional<std::string> options_json;    ///< BakeOptions::to_json() of the bake flags asked for
};

/// Never throws for a bad bundle: a missing or unreadable one is stale (baking fixes it).
BundleStatus bundle_status(const std::filesystem::path& bundle, const StatusQuery& query = {});

/// Records where the bake read each input, relative to the bundle's folder, so that
/// `status` finds them wherever the tree is checked out.
void record_input_paths(formats::BundleMetadata& metadata, const std::filesystem::path& mesh,
                        const std::filesystem::path& cage, const std::filesystem::path& bundle);

/// 0 when every bundle is up to date; kStatusStale when one is stale; kStatusMissingInput
/// when an input of one cannot be found (before stale: a person must look).
inline constexpr int kStatusStale = 3;
inline constexpr int kStatusMissingInput = 4;
int status_exit_code(const std::vector<BundleStatus>& statuses);

/// `verify --status`: the bundle's status as one more check ("status"), so that a CI
/// report goes red with the job when a bundle is stale or an input is missing.
formats::VerifyCheck status_check(const std::filesystem::path& bundle);

std::string status_text(const std::vector<BundleStatus>& statuses);
std::string status_json(const std::vector<BundleStatus>& statuses);

[[nodiscard]] const char* to_string(BundleState state);

}  // namespace fissure::bake
