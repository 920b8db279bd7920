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
#include <limits>
#include <memory>
#include <vector>

#include "bake/auto_cage.h"
#include "bake/bake.h"
#include "bake/memory_estimate.h"
#include "bake/cage_quality.h"
#include "bake/bundle_status.h"
#include "bake/replication.h"
#include "common/cli_numbers.h"
#include "common/error.h"
#include "common/log.h"
#include "common/output_file.h"
#include "formats/bundle_budgets.h"
#include "formats/bundle_checks.h"
#include "formats/bundle_inspect.h"
#include "formats/bundle.h"
#include "formats/cage_io.h"
#include "formats/cage_write.h"
#include "formats/junit.h"

namespace {

using namespace fissure;

/// The mesh, the cage as given, and both halves of a TetGen .node/.ele pair.
std::vector<std::filesystem::path> bake_inputs(const std::filesystem::path& mesh, const std::filesystem::path& cage) {
  std::vector<std::filesystem::path> inputs{mesh, cage};
  for (const auto& file : formats::cage_files(cage)) inputs.push_back(file);
  return inputs;
}

constexpr const char* kMemoryLimitHelp =
    "Refuse a mesh whose estimated memory (from its header or size, before reading it) is past this many GiB "
    "(default: the machine's memory)";

/// --memory-limit in bytes: the machine's memory when it was not given.
std::uint64_t memory_limit_bytes(const std::optional<double>& gib) {
  if (!gib) return bake::machine_memory_bytes();
  if (!(*gib > 0.0) || !std::isfinite(*gib)) {
    throw Error("--memory-limit must be a positive number of GiB", "leave it out for the machine's memory");
  }
  const double bytes = *gib * 1024.0 * 1024.0 * 1024.0;
  return bytes >= 1.8e19 ? std::numeric_limits<std::uint64_t>::max() : static_cast<std::uint64_t>(bytes);
}

constexpr const char* kKeepHolesHelp =
    "Keep a closed surface's through-holes open in the cage (as many as its genus), so the two sides of each can "
    "separate; fails naming the count that would, where the cells are too coarse. Without it, holes narrower than a "
    "few cells close";

/// The flags that shape a bundle's content, shared by `bake` and `status` (which compares
/// them with what a bundle was baked with).
struct BakeFlags {
  bool weld = false;
  std::vector<std::string> only, skip;
  int wall_res = static_cast<int>(bake::WallOptions{}.resolution);
  double wall_budget_mib = static_cast<double>(bake::WallOptions{}.memory_budget_bytes >> 20);
  std::optional<double> sphere_radius;
  double surface_spacing = 2.0;
  double winding_accuracy = bake::BakeOptions{}.winding_accuracy;
  std::string tets;  ///< as typed, parsed by bake::parse_tet_count
  std::string method = bake::AutoCageOptions{}.method;
  bool keep_holes = false;
  std::vector<CLI::Option*> options;  ///< to tell whether any was given

  void add_to(CLI::App* command) {
    options = {
        command->add_flag("--weld", weld, "Merge vertices at identical positions even across normal/UV seams"),
        command->add_option("--only", only, "Run only these optional stages: walls, collision (the embedding always runs)")
            ->check(CLI::IsMember({"walls", "collision"})),
        command->add_option("--skip", skip, "Skip these optional stages: walls, collision")
            ->check(CLI::IsMember({"walls", "collision"})),
        command->add_option("--wall-res", wall_res, "Wall tile resolution, texels per side")->capture_default_str(),
        command->add_option("--wall-memory-budget", wall_budget_mib, "Largest wall tile data to bake, MiB")
            ->capture_default_str(),
        command->add_option("--sphere-radius", sphere_radius,
                            "Target collision-sphere radius in mesh units (default: 4.5 % of the cube root of the mesh's volume)"),
        command->add_option("--surface-spacing", surface_spacing,
                            "Surface collision spheres, one per this many sphere radii of the surface (0: none); 1 lets "
                            "render vertices sink about half as deep at 1.5x the collision work (BENCHMARKS.md)")
            ->capture_default_str(),
        command->add_option("--winding-accuracy", winding_accuracy,
                            "Fast winding-number accuracy beta (larger = more exact, slower)")
            ->check(CLI::Range(1.0, 100.0))
            ->capture_default_str(),
        command->add_option("--tets", tets, "Make the cage from the mesh, with about this many tets (±15 %), instead of --cage"),
        command->add_option("--method", method,
                            "How --tets makes the cage: lattice (trimmed cubes, fast) or wrap (alpha wrap + Mesh_3, "
                            "shape-following)")
            ->capture_default_str(),
        command->add_flag("--keep-holes", keep_holes, kKeepHolesHelp),
    };
  }

  [[nodiscard]] bool any_given() const {
    return std::any_of(options.begin(), options.end(), [](const CLI::Option* o) { return o->count() > 0; });
  }

  [[nodiscard]] bool options_given(const std::string& name) const {
    return std::any_of(options.begin(), options.end(),
                       [&](const CLI::Option* o) { return o->count() > 0 && o->check_name(name); });
  }

  [[nodiscard]] bake::BakeOptions to_options() const {
    if (!only.empty() && !skip.empty()) throw Error("--only and --skip cannot be combined", "use one of them");
    auto listed = [](const std::vector<std::string>& list, const char* stage) {
      return std::find(list.begin(), list.end(), stage) != list.end();
    };
    bake::BakeOptions options;
    options.import.weld = weld;
    options.winding_accuracy = winding_accuracy;
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
    options.spheres.surface_spacing = surface_spacing;
    bake::validate(options.spheres);  // before any work
    if (!tets.empty()) {
      options.cage.tets = bake::parse_tet_count(tets);
      options.cage.method = method;
      options.cage.keep_holes = keep_holes;
      bake::validate(options.cage);
    } else if (options_given("--method") || options_given("--keep-holes")) {
      throw Error(std::string(options_given("--method") ? "--method" : "--keep-holes") +
                      " says how --tets makes a cage, but no --tets was given",
                  "add --tets N, or leave it out");
    }
    return options;
  }
};

int run_bake(const std::string& mesh, const std::string& cage, const std::string& output, const bake::BakeOptions& options,
             std::uint64_t memory_limit) {
  if (cage.empty() == !options.cage.enabled()) {
    throw Error(cage.empty() ? "bake needs a cage: give --cage FILE, or --tets N to make one from the mesh"
                             : "--cage and --tets both give the cage; use one of them",
                "--tets 1000 makes a lattice cage of about 1,000 tets; see fissure-bake cage --help");
  }
  // A bad output path fails now, not after the bake.
  check_output_path(output, cage.empty() ? std::vector<std::filesystem::path>{mesh} : bake_inputs(mesh, cage), "-o");
  bake::check_bake_memory(mesh, options.cage.tets, memory_limit);
  const StageTimer total("bake total");
  formats::Bundle bundle = cage.empty() ? bake::bake_with_auto_cage(mesh, options) : bake::bake_files(mesh, cage, options);
  bake::record_input_paths(bundle.metadata, mesh, cage, output);
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

struct CageArgs {
  std::string mesh, output, tets, method = bake::AutoCageOptions{}.method;
  bool json = false, weld = false, keep_holes = false;
  std::optional<double> memory_limit_gib;
};

/// `fissure-bake cage`: makes a cage from a mesh, checks that it holds every surface
/// point exactly, writes it and says what it is like.
int run_cage(const CageArgs& args) {
  bake::AutoCageOptions options;
  options.tets = bake::parse_tet_count(args.tets);
  options.method = args.method;
  options.keep_holes = args.keep_holes;
  bake::validate(options);
  if (!formats::is_cage_path(args.output)) {
    throw Error("-o " + args.output + ": not a cage file name",
                "name it .node (TetGen: writes .node and .ele), .msh (Gmsh 2.2) or .mesh (MEDIT)");
  }
  for (const auto& file : formats::cage_files(args.output)) check_output_path(file, {args.mesh}, "-o", "cage.node");
  bake::check_bake_memory(args.mesh, options.tets, memory_limit_bytes(args.memory_limit_gib));
  bake::MeshImportOptions import;
  import.weld = args.weld;
  const bake::ImportedMesh imported = bake::import_render_mesh(args.mesh, import);
  const bake::AutoCage cage = bake::make_cage(imported.mesh, options, args.mesh);
  // Nothing is written unless the cage holds the whole surface, checked exactly.
  bake::check_cage_covers(imported.mesh, cage.mesh, args.mesh, "the " + cage.method + " cage");
  const bake::CageQuality quality = bake::measure_cage(imported.mesh, cage.mesh);
  formats::write_cage(cage.mesh, args.output);
  if (args.json) {
    std::fputs(bake::quality_json(quality).c_str(), stdout);
    return 0;
  }
  std::printf("%s: %zu tets (asked %zu), %s, cell %.4g, in %.2f s\n", args.output.c_str(), cage.mesh.tet_count(),
              options.tets, cage.method.c_str(), cage.cell, cage.seconds);
  std::fputs(bake::quality_text(quality).c_str(), stdout);
  return 0;
}

int run_inspect(const std::string& path, bool json) {
  const formats::BundleSummary summary = formats::summarize_bundle(path);
  std::fputs((json ? formats::summary_json(summary) : formats::summary_text(summary)).c_str(), stdout);
  return 0;
}

struct StatusArgs {
  std::vector<std::string> bundles;
  std::string mesh, cage;
  bool json = false;
};

int run_status(const StatusArgs& args, const BakeFlags& flags) {
  bake::StatusQuery query;
  if (!args.mesh.empty()) query.mesh = args.mesh;
  if (!args.cage.empty()) query.cage = args.cage;
  if (flags.any_given()) query.options_json = flags.to_options().to_json();
  if (args.bundles.size() > 1 && (query.mesh || query.cage || query.options_json)) {
    throw Error("--mesh, --cage and bake flags describe one bundle, but " + std::to_string(args.bundles.size()) +
                    " were given",
                "ask about one bundle at a time, or leave them out to compare with what each bundle recorded");
  }
  std::vector<bake::BundleStatus> statuses;
  for (const std::string& bundle : args.bundles) statuses.push_back(bake::bundle_status(bundle, query));
  std::fputs((args.json ? bake::status_json(statuses) : bake::status_text(statuses)).c_str(), stdout);
  return bake::status_exit_code(statuses);
}

struct VerifyArgs {
  std::vector<std::string> bundles;
  std::string junit;
  std::optional<double> max_instances_per_triangle, max_size_mib;
  std::optional<std::uint64_t> max_spheres, max_tiles;
  bool status = false;  ///< also compare each bundle with its inputs, as `status` does

  [[nodiscard]] formats::BundleBudgets budgets() const {
    formats::BundleBudgets b;
    b.instances_per_triangle = max_instances_per_triangle;
    if (max_size_mib) b.file_bytes = static_cast<std::uint64_t>(*max_size_mib * 1024.0 * 1024.0);
    b.spheres = max_spheres;
    b.tiles = max_tiles;
    return b;
  }
};

/// "INVALID" only for a broken invariant; a bundle that is sound but over a budget or
/// stale says so, so a CI log tells a broken bake from a project limit.
std::string verdict(const formats::JunitSuite& suite) {
  if (suite.passed()) return "all invariants hold";
  bool invariant = false, budget = false, stale = false;
  for (const auto& check : suite.cases) {
    if (check.passed) continue;
    if (check.name == "status") stale = true;
    else if (check.name.rfind("budget:", 0) == 0) budget = true;
    else invariant = true;
  }
  if (invariant) return "INVALID";
  std::string text = budget ? "over budget" : "";
  if (stale) text += std::string(text.empty() ? "" : ", ") + "stale (re-bake it)";
  return text + " (invariants hold)";
}

/// One bundle's invariants and budgets, printed; a bundle that cannot be read is
/// reported (file and reason) and counted as failed, and the next one is checked.
formats::JunitSuite verify_one(const std::string& path, const formats::BundleBudgets& budgets, bool status) {
  formats::JunitSuite suite{path, {}, {}};
  try {
    const formats::Bundle bundle = formats::read_bundle(path);
    suite.cases = formats::verify_bundle(bundle).checks;
    for (auto& check : formats::check_budgets(bundle, std::filesystem::file_size(path), budgets)) suite.cases.push_back(check);
  } catch (const Error& e) {
    std::fflush(stdout);  // keep the earlier bundles' lines before this one's error
    std::fputs(format_error(e).c_str(), stderr);
    suite.error = e.what();
    return suite;
  }
  if (status) suite.cases.push_back(bake::status_check(path));
  // -q: the failures and the verdict only, for build logs; each failure names its bundle,
  // since the lines of many bundles interleave there.
  const bool quiet = log_level() < LogLevel::Info;
  for (const auto& check : suite.cases) {
    if (quiet && check.passed) continue;
    std::printf("%s%s  %-28s %s\n", quiet ? (path + ": ").c_str() : "", check.passed ? "PASS" : "FAIL",
                check.name.c_str(), check.detail.c_str());
  }
  std::printf("%s: %s\n", path.c_str(), verdict(suite).c_str());
  return suite;
}

int run_verify(const VerifyArgs& args) {
  std::vector<std::filesystem::path> bundles(args.bundles.begin(), args.bundles.end());
  if (!args.junit.empty()) check_output_path(args.junit, bundles, "--junit", "junit.xml");
  std::vector<formats::JunitSuite> suites;
  bool passed = true;
  for (const std::string& path : args.bundles) {
    suites.push_back(verify_one(path, args.budgets(), args.status));
    passed = passed && suites.back().passed();
  }
  if (!args.junit.empty()) write_file_atomically(args.junit, formats::junit_xml(suites));
  if (args.bundles.size() > 1) {
    std::printf("%zu bundles: %s\n", args.bundles.size(), passed ? "all pass" : "at least one FAILED (see above)");
  }
  return passed ? 0 : 1;
}

/// The command line: every subcommand's options, and which one was given.
struct Cli {
  CLI::App app{"fissure-bake: embed a render mesh in a tetrahedral cage and write a Fissure bundle (HDF5)."};
  bool quiet = false, verbose = false;
  int threads = 0;
  std::string mesh, cage, output;
  BakeFlags bake_flags;
  bool no_work_limit = false;
  std::optional<double> memory_limit_gib;
  std::string bundle_path;
  bool json = false;
  StatusArgs status_args;
  BakeFlags status_flags;
  VerifyArgs verify_args;
  std::vector<std::string> cages;
  CageArgs cage_args;
  CLI::App *bake_cmd = nullptr, *cage_cmd = nullptr, *inspect_cmd = nullptr, *status_cmd = nullptr,
           *verify_cmd = nullptr, *replication_cmd = nullptr;
};

void add_bake_command(Cli& cli) {
  cli.bake_cmd = cli.app.add_subcommand("bake", "Embed --mesh in --cage and write the bundle to -o");
  CLI::App* bake_cmd = cli.bake_cmd;
  bake_cmd->add_option("--mesh", cli.mesh, "Render mesh: PLY (own reader); OBJ, STL, glTF/GLB, FBX, … (via assimp)")
      ->required();
  bake_cmd->add_option("--cage", cli.cage,
                       "Tetrahedral cage: .node/.ele (TetGen), .msh (Gmsh 2.2/4.1), .mesh (MEDIT); or --tets to make one");
  bake_cmd->add_option("-o,--output", cli.output, "Bundle to write (.h5); written atomically")->required();
  cli.bake_flags.add_to(bake_cmd);
  bake_cmd->add_flag("--no-work-limit", cli.no_work_limit,
                     "Run a stage whose estimated work is past its limit (a very small --sphere-radius, a very "
                     "large --wall-res), however long it takes");
  bake_cmd->add_option("--memory-limit", cli.memory_limit_gib, kMemoryLimitHelp);
}

void add_cage_command(Cli& cli) {
  CageArgs& args = cli.cage_args;
  CLI::App* command = cli.cage_cmd = cli.app.add_subcommand(
      "cage", "Make a tetrahedral cage around --mesh with about --tets tets and write it to -o (.node, .msh or .mesh)");
  command->add_option("--mesh", args.mesh, "Render mesh: PLY (own reader); OBJ, STL, glTF/GLB, FBX, … (via assimp)")
      ->required();
  command->add_option("--tets", args.tets, "About how many tets (the cage lands within ±15 %)")->required();
  command->add_option("-o,--output", args.output, "Cage to write: .node (+ .ele), .msh (Gmsh 2.2), .mesh (MEDIT)")
      ->required();
  command->add_option("--method", args.method,
                      "lattice: trimmed cubes, 6 Kuhn tets each (min dihedral 45°, fast); wrap: an alpha-wrap envelope "
                      "meshed by CGAL Mesh_3 (shape-following, min dihedral 10°)")
      ->capture_default_str();
  command->add_flag("--keep-holes", args.keep_holes, kKeepHolesHelp);
  command->add_option("--memory-limit", args.memory_limit_gib, kMemoryLimitHelp);
  command->add_flag("--weld", args.weld, "Merge vertices at identical positions even across normal/UV seams");
  command->add_flag("--json", args.json, "The cage's quality as JSON on stdout");
}

void add_inspect_command(Cli& cli) {
  cli.inspect_cmd = cli.app.add_subcommand("inspect", "Summarise a bundle: counts, sizes, stages");
  cli.inspect_cmd->add_option("bundle", cli.bundle_path, "Bundle (.h5)")->required();
  cli.inspect_cmd->add_flag("--json", cli.json, "Machine-readable JSON on stdout");
}

void add_status_command(Cli& cli) {
  CLI::App* status_cmd = cli.status_cmd = cli.app.add_subcommand(
      "status",
      "Is each bundle what baking its inputs today would write? Compares the inputs' SHA-256 (found where the bake "
      "read them, relative to the bundle), the bake's version and, when bake flags are given, the options. "
      "Exit 0: all up to date; 3: one is stale (or missing, or unreadable); 4: an input cannot be found");
  StatusArgs& args = cli.status_args;
  status_cmd->add_option("bundles", args.bundles, "Bundles (.h5)")->required();
  status_cmd->add_option("--mesh", args.mesh, "The mesh to compare with (default: where the bake read it)");
  status_cmd->add_option("--cage", args.cage, "The cage to compare with (default: where the bake read it)");
  status_cmd->add_flag("--json", args.json, "Machine-readable JSON on stdout");
  cli.status_flags.add_to(status_cmd);
}

void add_verify_command(Cli& cli) {
  CLI::App* verify_cmd = cli.verify_cmd = cli.app.add_subcommand(
      "verify", "Check every invariant of each bundle, and the budgets given; exit 1 if one fails or cannot be read");
  VerifyArgs& args = cli.verify_args;
  verify_cmd->add_option("bundles", args.bundles, "Bundles (.h5)")->required();
  verify_cmd->add_option("--junit", args.junit,
                         "Also write a JUnit XML report (one suite per bundle, one case per check) for CI test reporters");
  verify_cmd->add_option("--max-instances-per-triangle", args.max_instances_per_triangle,
                         "Budget: stored triangle instances per render triangle (draw cost)")
      ->check(CLI::PositiveNumber);
  verify_cmd->add_option("--max-size-mib", args.max_size_mib, "Budget: the bundle file's size, MiB")
      ->check(CLI::PositiveNumber);
  verify_cmd->add_option("--max-spheres", args.max_spheres, "Budget: collision spheres (contact cost)");
  verify_cmd->add_option("--max-tiles", args.max_tiles, "Budget: wall tiles (texture memory)");
  verify_cmd->add_flag("--status", args.status,
                       "Also check that each bundle is up to date with its inputs (as `status` does): one more case each");
}

void add_replication_command(Cli& cli) {
  cli.replication_cmd =
      cli.app.add_subcommand("replication", "Count how often each triangle is stored, per cage (thesis Table II)");
  cli.replication_cmd->add_option("mesh", cli.mesh, "Render mesh")->required();
  cli.replication_cmd->add_option("--cages", cli.cages, "One or more cages")->required();
  cli.replication_cmd->add_flag("--json", cli.json, "Machine-readable JSON on stdout");
}

/// Runs the subcommand given; fissure::Error and other exceptions reach main.
int run_command(const Cli& cli) {
  if (*cli.bake_cmd) {
    bake::BakeOptions options = cli.bake_flags.to_options();
    if (cli.no_work_limit) {
      options.spheres.max_grid_points = 0;
      options.wall.max_work = 0;
    }
    return run_bake(cli.mesh, cli.cage, cli.output, options, memory_limit_bytes(cli.memory_limit_gib));
  }
  if (*cli.cage_cmd) return run_cage(cli.cage_args);
  if (*cli.inspect_cmd) return run_inspect(cli.bundle_path, cli.json);
  if (*cli.verify_cmd) return run_verify(cli.verify_args);
  if (*cli.status_cmd) return run_status(cli.status_args, cli.status_flags);
  if (*cli.replication_cmd) {
    const auto rows = bake::replication_study(cli.mesh, cli.cages, bake::BakeOptions{}.import);
    std::fputs((cli.json ? bake::replication_json(rows) : bake::replication_table(rows)).c_str(), stdout);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  fissure::install_output_signal_handlers();
  Cli cli;
  CLI::App& app = cli.app;
  app.set_version_flag("--version", fissure::bake::generator_string());
  app.require_subcommand(1);
  app.add_flag("-q,--quiet", cli.quiet, "Print only warnings, errors and the result");
  app.add_flag("-v,--verbose", cli.verbose, "Print debug detail");
  app.add_option("-j,--threads", cli.threads, "Worker threads (default: all cores)")->check(CLI::Range(0, kMaxThreads));
  add_bake_command(cli);
  add_cage_command(cli);
  add_inspect_command(cli);
  add_status_command(cli);
  add_verify_command(cli);
  add_replication_command(cli);
  fissure::refuse_non_finite_numbers(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return fissure::usage_exit_code(app, e);  // CLI11's own codes (105, 106, …) are not the contract's
  }
  set_log_level(cli.quiet ? LogLevel::Warning : (cli.verbose ? LogLevel::Debug : LogLevel::Info));
  std::unique_ptr<tbb::global_control> thread_limit;
  if (cli.threads > 0) {
    thread_limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                         static_cast<std::size_t>(cli.threads));
  }
  try {
    return run_command(cli);
  } catch (const fissure::Error& e) {
    std::fputs(fissure::format_error(e).c_str(), stderr);
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "internal error: %s\nhint: this is a bug in fissure-bake; please report it with the inputs\n",
                 e.what());
    return 2;
  }
}
