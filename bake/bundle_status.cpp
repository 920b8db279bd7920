#include "bake/bundle_status.h"

#include <algorithm>
#include <optional>
#include <utility>

#include "bake/bake.h"
#include "bake/collision_proxies.h"
#include "bake/file_hash.h"
#include "common/error.h"
#include "common/json_writer.h"
#include "formats/cage_io.h"

namespace fissure::bake {
namespace {

namespace fs = std::filesystem;

void mark(BundleStatus& status, BundleState state, std::string reason) {
  // Missing input outranks stale: it needs a person, not a re-bake.
  if (state == BundleState::MissingInput || status.state == BundleState::UpToDate) status.state = state;
  status.reasons.push_back(std::move(reason));
}

const formats::BundleInput* find_input(const formats::BundleMetadata& metadata, const std::string& role) {
  const auto it = std::find_if(metadata.inputs.begin(), metadata.inputs.end(),
                               [&](const formats::BundleInput& input) { return input.role == role; });
  return it == metadata.inputs.end() ? nullptr : &*it;
}

/// The files whose bytes the bake hashed for `role`, as the bake would read them.
std::vector<fs::path> hashed_files(const std::string& role, const fs::path& path) {
  return role == "cage" ? formats::cage_files(path) : std::vector<fs::path>{path};
}

void check_input(BundleStatus& status, const formats::BundleMetadata& metadata, const std::string& role,
                 const std::optional<fs::path>& asked) {
  const formats::BundleInput* stored = find_input(metadata, role);
  if (stored == nullptr) {
    mark(status, BundleState::Stale, "the bundle records no " + role + " input");
    return;
  }
  if (!asked && stored->path.empty()) {
    mark(status, BundleState::MissingInput,
         "the bundle does not record where its " + role + " (" + stored->name +
             ") was read (baked before schema 1.2): pass --" + role + ", or re-bake it");
    return;
  }
  const fs::path path = asked ? *asked : (status.bundle.parent_path() / fs::path(stored->path)).lexically_normal();
  const std::vector<fs::path> files = hashed_files(role, path);
  for (const fs::path& file : files) {
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) {
      // Where the bake read it, relative to the bundle: a bundle copied away from its
      // inputs lands here, and the flags that name them are the way out.
      mark(status, BundleState::MissingInput,
           role + " " + file.string() + " not found" +
               (asked ? "" : " (where the bake read it, relative to the bundle; if the bundle was copied away from "
                             "its inputs, pass --mesh and --cage)"));
      return;
    }
  }
  if (sha256_hex(files) != stored->sha256) {
    mark(status, BundleState::Stale, role + " " + path.string() + " changed since the bake");
  }
}

/// The top-level "key":value pairs of a flat JSON object as BakeOptions::to_json writes
/// it (values may be arrays of strings), value text as written.
std::vector<std::pair<std::string, std::string>> top_level_pairs(const std::string& json) {
  std::vector<std::pair<std::string, std::string>> pairs;
  std::size_t i = json.find('{');
  if (i == std::string::npos) return pairs;
  ++i;
  while (i < json.size() && json[i] == '"') {
    const std::size_t key_end = json.find('"', i + 1);
    if (key_end == std::string::npos || key_end + 1 >= json.size() || json[key_end + 1] != ':') break;
    std::size_t end = key_end + 2;
    int depth = 0;
    bool in_string = false;
    for (; end < json.size(); ++end) {
      const char c = json[end];
      if (in_string) {
        if (c == '\\') ++end;
        else if (c == '"') in_string = false;
      } else if (c == '"') {
        in_string = true;
      } else if (c == '[' || c == '{') {
        ++depth;
      } else if ((c == ']' || c == '}') && depth > 0) {
        --depth;
      } else if ((c == ',' || c == '}') && depth == 0) {
        break;
      }
    }
    pairs.emplace_back(json.substr(i + 1, key_end - i - 1), json.substr(key_end + 2, end - key_end - 2));
    i = end + 1;
  }
  return pairs;
}

/// "wall_resolution 64 -> 32, weld false -> true": the options that differ.
std::string options_difference(const std::string& baked, const std::string& asked) {
  const auto before = top_level_pairs(baked), after = top_level_pairs(asked);
  std::string text;
  auto value_in = [](const auto& pairs, const std::string& key) -> std::string {
    for (const auto& [k, v] : pairs) {
      if (k == key) return v;
    }
    return "(none)";
  };
  for (const auto& [key, value] : after) {
    const std::string old_value = value_in(before, key);
    if (old_value != value) text += (text.empty() ? "" : ", ") + key + " " + old_value + " -> " + value;
  }
  for (const auto& [key, value] : before) {
    if (value_in(after, key) == "(none)") text += (text.empty() ? "" : ", ") + key + " " + value + " -> (none)";
  }
  return text.empty() ? baked + " -> " + asked : text;
}

/// "collision spheres of model 1; this bake makes model 2" when the bundle's spheres were
/// made by another model than kSphereVersion (bundles before it record none: model 1);
/// empty when it has no collision stage or the same model.
std::string sphere_model_difference(const std::string& bake_options) {
  const auto pairs = top_level_pairs(bake_options);
  const auto value = [&](const std::string& key) -> std::optional<std::string> {
    for (const auto& [k, v] : pairs) {
      if (k == key) return v;
    }
    return std::nullopt;
  };
  const std::optional<std::string> stages = value("stages");
  if (!stages || stages->find("\"collision\"") == std::string::npos) return "";
  const std::string baked = value("sphere_version").value_or("1");
  if (baked == std::to_string(kSphereVersion)) return "";
  return "collision spheres of model " + baked + "; this bake makes model " + std::to_string(kSphereVersion) +
         " (spheres that follow the solid and reserve spheres for every render vertex)";
}

}  // namespace

BundleStatus bundle_status(const fs::path& bundle, const StatusQuery& query) {
  BundleStatus status{bundle, BundleState::UpToDate, {}};
  std::error_code ec;
  if (!fs::exists(bundle, ec)) {
    mark(status, BundleState::Stale, "not baked yet");
    return status;
  }
  formats::BundleMetadata metadata;
  try {
    metadata = formats::read_bundle(bundle).metadata;
  } catch (const Error& e) {
    mark(status, BundleState::Stale, std::string("cannot be read: ") + e.what());
    return status;
  }
  if (metadata.generator != generator_string()) {
    mark(status, BundleState::Stale, "baked by " + metadata.generator + "; this is " + generator_string());
  }
  if (const std::string spheres = sphere_model_difference(metadata.bake_options); !spheres.empty()) {
    mark(status, BundleState::Stale, spheres);
  }
  try {
    check_input(status, metadata, "mesh", query.mesh);
    // An automatic cage is no file: the mesh, the options (method, count, cage version)
    // and the bake's version, all compared here, are what made it.
    const bool automatic = metadata.bake_options.find("\"cage_method\"") != std::string::npos;
    if (!automatic) {
      check_input(status, metadata, "cage", query.cage);
    } else if (query.cage) {
      mark(status, BundleState::Stale, "baked on an automatic cage, not on " + query.cage->string());
    }
  } catch (const Error& e) {  // an input that exists but cannot be read
    mark(status, BundleState::MissingInput, e.what());
  }
  if (query.options_json && *query.options_json != metadata.bake_options) {
    mark(status, BundleState::Stale, "options differ: " + options_difference(metadata.bake_options, *query.options_json));
  }
  return status;
}

void record_input_paths(formats::BundleMetadata& metadata, const fs::path& mesh, const fs::path& cage,
                        const fs::path& bundle) {
  // Relative to the bundle's folder, so a checkout elsewhere still finds them; both made
  // absolute first, so "a.obj" and "out/b.h5" relate as the shell sees them.
  const fs::path folder = fs::absolute(bundle).parent_path();
  for (formats::BundleInput& input : metadata.inputs) {
    const fs::path& path = input.role == "mesh" ? mesh : cage;
    input.path = fs::absolute(path).lexically_relative(folder).generic_string();
  }
}

int status_exit_code(const std::vector<BundleStatus>& statuses) {
  int code = 0;
  for (const BundleStatus& s : statuses) {
    if (s.state == BundleState::MissingInput) return kStatusMissingInput;
    if (s.state == BundleState::Stale) code = kStatusStale;
  }
  return code;
}

formats::VerifyCheck status_check(const fs::path& bundle) {
  const BundleStatus status = bundle_status(bundle);
  if (status.state == BundleState::UpToDate) return {"status", true, "inputs, options and bake version match"};
  std::string detail = to_string(status.state);
  for (const std::string& reason : status.reasons) detail += "; " + reason;
  return {"status", false, detail};
}

const char* to_string(BundleState state) {
  switch (state) {
    case BundleState::UpToDate: return "up-to-date";
    case BundleState::Stale: return "stale";
    case BundleState::MissingInput: return "missing-input";
  }
  return "?";
}

std::string status_text(const std::vector<BundleStatus>& statuses) {
  std::string text;
  for (const BundleStatus& s : statuses) {
    text += s.bundle.string() + ": " + to_string(s.state) + "\n";
    for (const std::string& reason : s.reasons) text += "  " + reason + "\n";
  }
  return text;
}

std::string status_json(const std::vector<BundleStatus>& statuses) {
  JsonWriter j;
  j.begin_object().key("up_to_date").value(status_exit_code(statuses) == 0).key("bundles").begin_array();
  for (const BundleStatus& s : statuses) {
    j.begin_object().key("bundle").value(s.bundle.string()).key("state").value(to_string(s.state));
    j.key("reasons").begin_array();
    for (const std::string& reason : s.reasons) j.value(reason);
    j.end_array().end_object();
  }
  j.end_array().end_object();
  return j.str() + "\n";
}

}  // namespace fissure::bake
