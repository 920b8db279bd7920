// fissure-bake: the offline half of Fissure. A thin CLI over the fissure_bake library.
#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include <chrono>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <iostream>
#include <filesystem>
#include <memory>
#include <vector>

#include "bake/bake.h"
#include "bake/replication.h"
#include "common/error.h"
#include "common/log.h"
#include "common/output_file.h"
#include "formats/bundle_checks.h"
#include "formats/bundle_inspect.h"
#include "formats/bundle.h"

namespace {

using namespace fissure;

/// The cage as given, and the other half of a TetGen .node/.ele pair.
std::vector<std::filesystem::path> bake_inputs(const std::filesystem::path& mesh, const std::filesystem::path& cage) {
  std::vector<std::filesystem::path> inputs{mesh, cage};
  for (const char* extension : {".node", ".ele"}) inputs.push_back(std::filesystem::path(cage).replace_extension(extension));
  return inputs;
}

int run_bake(const std::string& mesh, const std::string& cage, const std::string& output, const bake::BakeOptions& options) {
  // A bad output path fails now, not after the bake.
  check_output_path(output, bake_inputs(mesh, cage), "-o");
  const StageTimer total("bake total");
  const formats::Bundle bundle = bake::bake_files(mesh, cage, options);
  // The bake checks its own result before writing: a bundle on disk always verifies.
  const auto verify_start = std::chrono::steady_clock::now();
  const formats::VerifyReport report = formats::verify_bundle(bundle);
  log_debug("verify before writing: " +
            std::to_string(std::chrono::duration<double>(std::chrono::steady_clock::now() - verify_start).count()) + " s");
  if (!report.passed()) {
    for (const auto& check : report.checks) {
      if (!check.passed) std::fprintf(stderr, "internal error: %s: %s\n", check.name.c_str(), check.detail.c_str());
    }
    std::fprintf(stderr, "hint: this is a bug in fissure-bake; please report it with the inputs. Nothing was written.\n");
    return 2;
  }
  const auto write_start = std::chrono::steady_clock::now();
  formats::write_bundle(output, bundle);
  log_debug("write: " +
            std::to_string(std::chrono::duration<double>(std::chrono::steady_clock::now() - write_start).count()) + " s");
  const auto& e = bundle.embedding;
  std::printf("%s: %zu triangles in %zu tets -> %zu instances, %zu contour segments\n", output.c_str(),
              bundle.render.triangle_count(), bundle.cage.tet_count(), e.instance_count(), e.segment_count());
  return 0;
}

int run_inspect(const std::string& path, bool json) {
  const formats::BundleSummary summary = formats::summarize_bundle(path);
  std::fputs((json ? formats::summary_json(summary) : formats::summary_text(summary)).c_str(), stdout);
  return 0;
}

int run_verify(const std::string& path) {
  const formats::Bundle bundle = formats::read_bundle(path);
  const formats::VerifyReport report = formats::verify_bundle(bundle);
  for (const auto& check : report.checks) {
    std::printf("%s  %-28s %s\n", check.passed ? "PASS" : "FAIL", check.name.c_str(), check.detail.c_str());
  }
  std::printf("%s: %s\n", path.c_str(), report.passed() ? "all invariants hold" : "INVALID");
  return report.passed() ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  fissure::install_output_signal_handlers();
  CLI::App app{"fissure-bake: embed a render mesh in a tetrahedral cage and write a Fissure bundle (HDF5)."};
  app.set_version_flag("--version", fissure::bake::generator_string());
  app.require_subcommand(1);
  bool quiet = false, verbose = false;
  int threads = 0;
  app.add_flag("-q,--quiet", quiet, "Print only warnings, errors and the result");
  app.add_flag("-v,--verbose", verbose, "Print debug detail");
  app.add_option("-j,--threads", threads, "Worker threads (default: all cores)")->check(CLI::Range(0, kMaxThreads));

  fissure::bake::BakeOptions options;
  std::string mesh, cage, output;
  auto* bake_cmd = app.add_subcommand("bake", "Embed --mesh in --cage and write the bundle to -o");
  bake_cmd->add_option("--mesh", mesh, "Render mesh: PLY (own reader); OBJ, STL, glTF/GLB, FBX, … (via assimp)")->required();
  bake_cmd->add_option("--cage", cage, "Tetrahedral cage: .node/.ele (TetGen), .msh (Gmsh 2.2/4.1), .mesh (MEDIT)")
      ->required();
  bake_cmd->add_option("-o,--output", output, "Bundle to write (.h5); written atomically")->required();
  bake_cmd->add_flag("--weld", options.import.weld,
                     "Merge vertices at identical positions even across normal/UV seams");
  std::vector<std::string> only, skip;
  int wall_res = static_cast<int>(options.wall.resolution);
  double wall_budget_mib = static_cast<double>(options.wall.memory_budget_bytes >> 20);
  std::optional<double> sphere_radius;
  bake_cmd->add_option("--only", only, "Run only these optional stages: walls, collision (the embedding always runs)")
      ->check(CLI::IsMember({"walls", "collision"}));
  bake_cmd->add_option("--skip", skip, "Skip these optional stages: walls, collision")
      ->check(CLI::IsMember({"walls", "collision"}));
  bake_cmd->add_option("--wall-res", wall_res, "Wall tile resolution, texels per side")->capture_default_str();
  bake_cmd->add_option("--wall-memory-budget", wall_budget_mib, "Largest wall tile data to bake, MiB")
      ->capture_default_str();
  bake_cmd->add_option("--sphere-radius", sphere_radius,
                       "Target collision-sphere radius in mesh units (default: a fifth of the median cage edge)");
  bake_cmd->add_option("--winding-accuracy", options.winding_accuracy,
                       "Fast winding-number accuracy beta (larger = more exact, slower)")
      ->check(CLI::Range(1.0, 100.0))
      ->capture_default_str();

  std::string bundle_path;
  bool json = false;
  auto* inspect_cmd = app.add_subcommand("inspect", "Summarise a bundle: counts, sizes, stages");
  inspect_cmd->add_option("bundle", bundle_path, "Bundle (.h5)")->required();
  inspect_cmd->add_flag("--json", json, "Machine-readable JSON on stdout");

  auto* verify_cmd = app.add_subcommand("verify", "Check every invariant of a bundle; exit 1 if one fails");
  verify_cmd->add_option("bundle", bundle_path, "Bundle (.h5)")->required();

  std::vector<std::string> cages;
  auto* replication_cmd =
      app.add_subcommand("replication", "Count how often each triangle is stored, per cage (thesis Table II)");
  replication_cmd->add_option("mesh", mesh, "Render mesh")->required();
  replication_cmd->add_option("--cages", cages, "One or more cages")->required();
  replication_cmd->add_flag("--json", json, "Machine-readable JSON on stdout");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  set_log_level(quiet ? LogLevel::Warning : (verbose ? LogLevel::Debug : LogLevel::Info));
  std::unique_ptr<tbb::global_control> thread_limit;
  if (threads > 0) {
    thread_limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                         static_cast<std::size_t>(threads));
  }

  try {
    if (*bake_cmd) {
      if (!only.empty() && !skip.empty()) throw Error("--only and --skip cannot be combined", "use one of them");
      auto listed = [](const std::vector<std::string>& list, const char* stage) {
        return std::find(list.begin(), list.end(), stage) != list.end();
      };
      options.walls = only.empty() ? !listed(skip, "walls") : listed(only, "walls");
      options.collision = only.empty() ? !listed(skip, "collision") : listed(only, "collision");
      if (wall_res <= 0) throw Error("--wall-res " + std::to_string(wall_res) + " must be positive", "use 8 … 256");
      options.wall.resolution = static_cast<std::uint32_t>(wall_res);
      if (!(wall_budget_mib > 0)) throw Error("--wall-memory-budget must be positive (MiB)");
      options.wall.memory_budget_bytes = static_cast<std::size_t>(wall_budget_mib * 1024.0 * 1024.0);
      if (sphere_radius) {
        if (!(*sphere_radius > 0.0) || !std::isfinite(*sphere_radius)) {
          throw Error("--sphere-radius " + std::to_string(*sphere_radius) + " must be a positive length",
                      "give a radius in the mesh's units, e.g. 0.005, or leave it out for the default");
        }
        options.spheres.radius = *sphere_radius;
      }
      return run_bake(mesh, cage, output, options);
    }
    if (*inspect_cmd) return run_inspect(bundle_path, json);
    if (*verify_cmd) return run_verify(bundle_path);
    if (*replication_cmd) {
      const auto rows = fissure::bake::replication_study(mesh, cages, options.import);
      std::fputs((json ? fissure::bake::replication_json(rows) : fissure::bake::replication_table(rows)).c_str(), stdout);
      return 0;
    }
  } catch (const fissure::Error& e) {
    std::fputs(fissure::format_error(e).c_str(), stderr);
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "internal error: %s\nhint: this is a bug in fissure-bake; please report it with the inputs\n",
                 e.what());
    return 2;
  }
  return 0;
}
