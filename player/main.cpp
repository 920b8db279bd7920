// fissure-player: the runtime half of Fissure. A thin CLI over the scene reader, the
// physics, the headless renderer (frames and video) and the interactive viewer. It sits
// above player/app/ (run) and player/view/ (view), so neither imports the other.
#include <CLI/CLI.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <tuple>

#include "common/cli_numbers.h"
#include "common/error.h"
#include "common/log.h"
#include "common/output_file.h"
#include "formats/scene.h"
#include "player/app/run.h"
#include "player/view/viewer.h"

namespace {

using namespace fissure;

/// `run`'s command line, as parsed.
struct RunArgs {
  std::string scene_path;
  player::RunOptions options;
  bool no_render = false, no_walls = false, no_normal_mapping = false;
  bool no_diagnostics = false, no_energy_check = false;
  int threads = -1;
  std::string report, step_log, trajectory, frames, video, size = "1280x720", backend = "osmesa";
};

/// `view`'s command line, as parsed.
struct ViewArgs {
  std::string scene_path, size = "1280x720", screenshot, script, replay;
  view::ViewOptions options;
  bool no_panel = false;
};

void add_image_options(CLI::App* run, RunArgs& a) {
  run->add_flag("--no-render", a.no_render, "Make no images (the default without --frames or --video)");
  run->add_option("--frames", a.frames, "Write the frames as PNG files (frame-00000.png …) and frames.json into this folder");
  run->add_option("--video", a.video, "Write an H.264 video (needs ffmpeg), e.g. out/drop.mp4");
  run->add_option("--size", a.size, "Image size, WIDTHxHEIGHT")->capture_default_str();
  run->add_option("--fps", a.options.images.fps, "Frames per simulated second (independent of solver.dt)")->capture_default_str();
  run->add_flag("--no-walls", a.no_walls, "Do not draw the walls fracture opens (the mesh alone, cracks show through)");
  run->add_flag("--no-normal-mapping", a.no_normal_mapping, "Draw the walls flat, without the detail normals");
  run->add_option("--tessellation", a.options.images.tessellation,
                  "Relief on the walls inside the solid: the most segments per wall edge, e.g. 8 for close-ups "
                  "(0 or 1: off, walls flat with normal mapping)")
      ->check(CLI::Range(0.0f, 64.0f))
      ->capture_default_str();
  run->add_flag("--fragment-colors", a.options.images.fragment_colors, "Debug view: each fragment in its own colour");
  run->add_flag("--cage", a.options.images.cage, "Debug view: draw the cages' edges over the image");
  run->add_flag("--spheres", a.options.images.spheres,
                "Debug view: draw each body's collision spheres in place of its surface");
  run->add_flag("--replication-colors", a.options.images.replication_colors,
                "Debug view: colour each triangle by how many tets it is drawn in (1 grey-green, 2 yellow, 3 orange, "
                "4 red, 5+ purple)");
  run->add_option("--backend", a.backend, "Headless OpenGL: osmesa (software, the default) or egl (surfaceless; a GPU's driver where there is one)")
      ->capture_default_str();
}

CLI::App* add_run_command(CLI::App& app, RunArgs& a) {
  CLI::App* run = app.add_subcommand("run", "Simulate a scene file (see docs/scene-example.toml)");
  run->add_option("scene", a.scene_path, "Scene file (TOML)")->required();
  add_image_options(run, a);
  run->add_option("--steps", a.options.steps, "Number of steps of solver.dt (at most 1e9)")
      ->check(CLI::Range(0L, 1'000'000'000L))  // 9e18 steps would run for ever
      ->capture_default_str();
  run->add_option("--report", a.report, "Write a JSON report (timings per phase, energy, momentum, fragments, penetration)");
  run->add_option("--step-log", a.step_log,
                  "Write a CSV line per step (each phase's ms, iterations, factorizations, splits, contacts), to find what "
                  "made a step slow");
  run->add_option("--trajectory", a.trajectory, "Write node trajectories and fracture events (HDF5)");
  run->add_option("--trajectory-every", a.options.trajectory_every, "Record every k-th step in the trajectory")
      ->capture_default_str();
  run->add_flag("--no-energy-check", a.no_energy_check,
                "Report a run that creates energy, but run it on to the end (by default it stops with exit 1)");
  run->add_flag("--no-diagnostics", a.no_diagnostics,
                "Skip the per-step energy and penetration checks (the report then has no energy or penetration)");
  run->add_option("-j,--threads", a.threads, "Worker threads (default: solver.threads of the scene; 0 = all cores)")
      ->check(CLI::Range(0, kMaxThreads));
  return run;
}

CLI::App* add_view_command(CLI::App& app, ViewArgs& a) {
  CLI::App* view = app.add_subcommand("view", "Play a scene in a window, with a panel to break and tune it live");
  view->add_option("scene", a.scene_path, "Scene file (TOML)")->required();
  view->add_option("--size", a.size, "Window size, WIDTHxHEIGHT")->capture_default_str();
  view->add_flag("--paused", a.options.paused, "Start paused (space resumes, N steps)");
  view->add_option("--steps-per-frame", a.options.steps_per_frame,
                   "Take exactly this many steps per frame instead of running in real time (repeatable runs)")
      ->check(CLI::Range(0, 1000));
  view->add_option("--exit-after-frames", a.options.exit_after_frames, "Close after this many frames")
      ->check(CLI::Range(0L, 100'000'000L));
  view->add_option("--screenshot", a.screenshot, "At exit, write the last frame (without the panel) as PNG");
  view->add_option("--script", a.script,
                   "Take actions from a file, one per frame: wait N, pause, resume, step N, fire X Y, shot MASS RADIUS SPEED, toggle FEATURE, "
                   "set OBJECT PARAM VALUE, screenshot PATH, quit (see player/view/view_script.h)");
  view->add_flag("--no-panel", a.no_panel, "Hide the panel (H toggles it)");
  view->add_option("--replay", a.replay,
                   "Play a trajectory recorded by `run --trajectory` with this scene, on a timeline to scrub "
                   "(left/right arrows: a frame back/on)");
  view->footer(
      "Mouse: left drag orbits, right or middle drag (or shift + left) pans, wheel zooms, a left click fires a "
      "projectile through the cursor.\nKeys: space pause/resume, N one step, R reset, F the scene's framing, "
      "P screenshot, H panel, Esc quit.\nNeeds a display; without one use `run --frames` (or xvfb-run -a).");
  return view;
}

int view_command(ViewArgs& a) {
  std::tie(a.options.width, a.options.height) = player::parse_size(a.size);
  a.options.screenshot = a.screenshot;
  a.options.script = a.script;
  a.options.panel = !a.no_panel;
  a.options.replay = a.replay;
  return view::view_scene(formats::read_scene(a.scene_path), a.options);
}

int run_command(RunArgs& a) {
  if (a.no_render && (!a.frames.empty() || !a.video.empty())) {
    throw Error("--no-render contradicts --frames and --video", "leave out --no-render to make images");
  }
  player::RunOptions& options = a.options;
  options.images.frames = a.frames;
  options.images.video = a.video;
  std::tie(options.images.width, options.images.height) = player::parse_size(a.size);
  options.images.backend = render::parse_backend(a.backend);
  options.images.walls = !a.no_walls;
  options.images.normal_mapping = !a.no_normal_mapping;
  const formats::Scene scene = formats::read_scene(a.scene_path);
  const int wanted = a.threads >= 0 ? a.threads : scene.solver.threads;
  std::unique_ptr<tbb::global_control> limit;
  if (wanted > 0) {
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                  static_cast<std::size_t>(wanted));
  }
  options.report = a.report;
  options.trajectory = a.trajectory;
  options.step_log = a.step_log;
  options.diagnostics = !a.no_diagnostics;
  options.energy_check = !a.no_energy_check;
  return player::run_scene(scene, options);
}

}  // namespace

int main(int argc, char** argv) {
  fissure::install_output_signal_handlers();
  CLI::App app{"fissure-player: simulate baked Fissure bundles (corotational FEM, fracture, sphere collisions)"};
  app.require_subcommand(1);
  bool quiet = false, verbose = false;
  app.add_flag("-q,--quiet", quiet, "Print only warnings, errors and the result");
  app.add_flag("-v,--verbose", verbose, "Print debug detail");
  RunArgs run_args;
  ViewArgs view_args;
  add_run_command(app, run_args);
  CLI::App* view = add_view_command(app, view_args);
  fissure::refuse_non_finite_numbers(app);  // NaN passes CLI11's range checks
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // CLI11 prints the message or the help; a bad command line is exit 1, like any bad input.
    return app.exit(e) == 0 ? 0 : 1;
  }
  set_log_level(quiet ? LogLevel::Warning : (verbose ? LogLevel::Debug : LogLevel::Info));
  try {
    return view->parsed() ? view_command(view_args) : run_command(run_args);
  } catch (const Error& e) {
    std::fputs(format_error(e).c_str(), stderr);
    return 1;
  } catch (const std::filesystem::filesystem_error& e) {
    // A path the system refused (too long, a folder that cannot be read, a rename that
    // cannot be done): the user's to fix, not a bug.
    const std::string message = e.path1().empty() ? std::string(e.what()) : e.path1().string() + ": " + e.code().message();
    std::fputs(format_error(Error(message, "check the path: its length, and that its folders exist and can be used")).c_str(),
               stderr);
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "internal error: %s\nhint: this is a bug in fissure-player; please report it with the scene\n",
                 e.what());
    return 2;
  }
}
