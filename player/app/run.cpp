#include "player/app/run.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>

#include "common/error.h"
#include "common/input_file.h"
#include "common/log.h"
#include "common/output_file.h"
#include "player/app/diagnostics.h"
#include "player/app/run_loop.h"
#include "player/app/run_report.h"
#include "player/app/run_statistics.h"
#include "player/app/scene_loader.h"
#include "player/app/step_log.h"
#include "player/app/trajectory_recorder.h"

namespace fissure::player {

namespace {

using Clock = std::chrono::steady_clock;

/// Observer: a line on stderr every two seconds of a long run.
class ProgressLog : public RunObserver {
 public:
  explicit ProgressLog(long steps) : m_steps(steps) {}
  void on_start(const sim::World& /*world*/) override { m_last = Clock::now(); }
  void on_step(const sim::World& world, const sim::StepReport& report, long step) override {
    m_step_seconds += report.total;
    if (std::chrono::duration<double>(Clock::now() - m_last).count() <= 2.0) return;
    m_last = Clock::now();
    log_info("step " + std::to_string(step) + "/" + std::to_string(m_steps) + "  t = " +
             std::to_string(world.time()).substr(0, 6) + " s  fragments " + std::to_string(world.fragment_count()) +
             "  " + std::to_string(1e3 * m_step_seconds / static_cast<double>(step)).substr(0, 6) + " ms/step");
  }

 private:
  long m_steps;
  double m_step_seconds = 0;
  Clock::time_point m_last;
};

void log_loaded(const formats::Scene& scene, const sim::World& world, double seconds) {
  std::size_t tets = 0, nodes = 0, spheres = 0, vertices = 0;
  for (const sim::Body& b : world.bodies()) {
    tets += b.integrator().elasticity().tet_count();
    nodes += b.integrator().node_count();
    spheres += b.spheres.size();
    vertices += b.vertices.size();
  }
  log_info(scene.file.filename().string() + ": " + std::to_string(world.bodies().size()) + " bodies, " +
           std::to_string(tets) + " tets, " + std::to_string(nodes) + " nodes, " + std::to_string(spheres) +
           " spheres, " + std::to_string(vertices) + " render vertices; loaded in " +
           std::to_string(seconds).substr(0, 5) + " s");
}

/// Frames at a fixed rate, whatever dt: before frame f the physics has taken the whole
/// number of steps nearest f / fps (counted in steps, so rounding never drifts), and the
/// run takes exactly `steps` steps, the same as without frames. A frame that cannot be
/// written (a PNG write failing, ffmpeg dying) ends the run there: the error goes to
/// `failure`, and the run is finished so its report can still be written.
RunEnd run_with_frames(RunLoop& loop, const sim::World& world, FrameOutput& images, const RunOptions& options,
                       std::optional<Error>& failure) {
  const double steps_per_frame = 1.0 / (options.images.fps * world.settings().step.dt);
  loop.start();
  // Only the frames' own errors end the run here; an error of the physics leaves as it
  // would without frames.
  const auto capture = [&](int steps, double physics_ms) {
    try {
      images.capture(world, steps, physics_ms);
    } catch (const Error& e) {
      failure = e;
    }
    return !failure;
  };
  long taken = 0;
  if (capture(0, 0.0)) {
    for (long f = 1; !loop.stopped(); ++f) {
      const long target = std::llround(static_cast<double>(f) * steps_per_frame);
      if (target > options.steps) break;
      const auto start = Clock::now();
      const long steps = loop.take_steps(target - taken);
      taken += steps;
      const double physics_ms = 1e3 * std::chrono::duration<double>(Clock::now() - start).count();
      if (loop.stopped() || !capture(static_cast<int>(steps), physics_ms)) break;
    }
    if (!failure) loop.take_steps(options.steps - taken);  // what is left after the last whole frame
  }
  return loop.finish();
}

void print_images(const FrameOptions& options, const FrameOutput& images) {
  const std::vector<FrameRecord>& records = images.records();
  double render = 0, output = 0;
  std::size_t first_upload = 0, later_uploads = 0;
  for (std::size_t f = 0; f < records.size(); ++f) {
    render += records[f].render_ms;
    output += records[f].output_ms;
    (f == 0 ? first_upload : later_uploads) += records[f].upload_bytes;
  }
  // The first frame uploads the static buffers (instances, tiles); later ones the motion.
  const double n = static_cast<double>(std::max<std::size_t>(records.size(), 1));
  const double later = static_cast<double>(later_uploads) / std::max(n - 1.0, 1.0);
  std::printf("frames     %zu at %d/s, %dx%d (%s): render %.1f ms/frame, output %.1f ms/frame; uploaded %zu bytes "
              "first, then %.0f per frame\n",
              records.size(), options.fps, options.width, options.height, images.renderer_description().c_str(),
              render / n, output / n, first_upload, later);
  if (!options.frames.empty()) std::printf("images     %s\n", (options.frames / "frame-NNNNN.png").string().c_str());
  if (!options.video.empty()) std::printf("video      %s\n", options.video.string().c_str());
}

/// Outputs fail before the run when they cannot be written or would replace an input.
void check_outputs(const formats::Scene& scene, const RunOptions& options) {
  std::vector<std::filesystem::path> inputs{scene.file};
  for (const formats::SceneObject& object : scene.objects) inputs.push_back(object.bundle);
  if (!options.report.empty()) check_output_path(options.report, inputs, "--report", "report.json");
  if (!options.trajectory.empty()) check_output_path(options.trajectory, inputs, "--trajectory", "trajectory.h5");
  if (!options.step_log.empty()) check_output_path(options.step_log, inputs, "--step-log", "steps.csv");
  if (!options.images.video.empty()) check_output_path(options.images.video, inputs, "--video", "video.mp4");
  const auto& frames = options.images.frames;
  std::error_code ec;
  if (!frames.empty() && std::filesystem::exists(frames, ec) && !std::filesystem::is_directory(frames, ec)) {
    const std::string kind = special_file_kind(frames);
    throw Error("--frames " + frames.string() + ": is " + (kind.empty() ? "a file" : kind) + ", not a folder",
                "give a folder for the frames");
  }
  if (!frames.empty() && std::filesystem::is_directory(frames, ec)) {
    // The frames replace files of the same name: never a FIFO or a device left there.
    // One pass over the folder, which may hold thousands of frames of an earlier run.
    for (const auto& entry : std::filesystem::directory_iterator(frames, ec)) {
      const std::string name = entry.path().filename().string();
      if (name != "frames.json" && !(name.rfind("frame-", 0) == 0 && entry.path().extension() == ".png")) continue;
      if (const std::string kind = special_file_kind(entry.path()); !kind.empty()) {
        throw Error("--frames " + entry.path().string() + ": is " + kind + ", which a frame would replace",
                    "remove it, or give another folder for the frames");
      }
    }
  }
}

}  // namespace

int run_scene(const formats::Scene& scene, const RunOptions& options) {
  if (options.steps < 0) throw Error("--steps " + std::to_string(options.steps) + " is negative", "give 0 or more steps");
  check_outputs(scene, options);
  std::optional<TrajectoryRecorder> trajectory;
  if (!options.trajectory.empty()) {
    trajectory.emplace(options.trajectory, scene.file.filename().string(), options.trajectory_every);
  }
  const auto load_start = Clock::now();
  LoadedScene loaded = load_scene(scene);
  const double load_seconds = std::chrono::duration<double>(Clock::now() - load_start).count();
  log_loaded(scene, loaded.world, load_seconds);

  RunLoop loop(loaded.world);
  RunStatistics statistics;
  loop.add(statistics);
  std::optional<Diagnostics> diagnostics;
  if (options.diagnostics) {
    loop.add(diagnostics.emplace());
    diagnostics->stop_on_energy_gain = options.energy_check;
  }
  if (trajectory) loop.add(*trajectory);
  std::optional<StepLog> step_log;
  if (!options.step_log.empty()) loop.add(step_log.emplace(options.step_log));
  ProgressLog progress(options.steps);
  loop.add(progress);
  std::unique_ptr<FrameOutput> images;
  if (options.images.wanted()) images = std::make_unique<FrameOutput>(options.images, loaded);
  std::optional<Error> image_failure;
  const RunEnd end = images ? run_with_frames(loop, loaded.world, *images, options, image_failure)
                            : loop.run_steps(options.steps);

  RunRecord record{scene.file.filename().string(), {}, load_seconds, &statistics, diagnostics ? &*diagnostics : nullptr, end};
  for (const BodyAssets& a : loaded.assets) record.bundles.push_back(a.bundle_name);
  print_summary(loaded.world, record);
  if (!options.report.empty()) {
    write_report(options.report, loaded.world, record);
    std::printf("report     %s\n", options.report.string().c_str());
  }
  if (step_log) std::printf("step log   %s\n", step_log->path().string().c_str());
  if (trajectory) std::printf("trajectory %s (%zu frames)\n", trajectory->path().string().c_str(), trajectory->frame_count());
  if (image_failure) throw *image_failure;  // after the report, which holds the run up to the failed frame
  if (images) {
    images->finish();  // after the report: a failing ffmpeg must not cost the run's record
    print_images(options.images, *images);
  }
  if (end.ok()) return 0;
  const sim::StepFailure failure =
      end.stop ? sim::StepFailure{end.stop->message, end.stop->hint} : loaded.world.explain(end.status);
  const std::string message = "stopped after " + std::to_string(end.steps) + " steps: " + failure.message;
  std::fputs(format_error(Error(message, failure.hint)).c_str(), stderr);
  return 1;
}

}  // namespace fissure::player
