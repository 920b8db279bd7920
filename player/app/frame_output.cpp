#include "player/app/frame_output.h"

#include <chrono>
#include <cstdio>

#include "common/error.h"
#include "common/json_writer.h"
#include "common/output_file.h"
#include "common/log.h"
#include "formats/image.h"

namespace fissure::player {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point start) { return 1e3 * std::chrono::duration<double>(Clock::now() - start).count(); }

std::string frame_name(std::size_t index) {
  char name[32];
  std::snprintf(name, sizeof name, "frame-%05zu.png", index);
  return name;
}

}  // namespace

std::pair<int, int> parse_size(const std::string& text) {
  int width = 0, height = 0;
  char x = 0, rest = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &width, &x, &height, &rest) != 3 || x != 'x' || width < 16 ||
      height < 16 || width > 8192 || height > 8192) {
    throw Error("--size " + text + " is not WIDTHxHEIGHT with sides from 16 to 8192", "e.g. --size 1280x720");
  }
  return {width, height};
}

FrameOutput::FrameOutput(const FrameOptions& options, const LoadedScene& scene) : m_options(options) {
  if (options.fps < 1 || options.fps > 1000) {
    throw Error("--fps " + std::to_string(options.fps) + " is out of range", "use 1 to 1000 frames per second");
  }
  if (!options.frames.empty()) {
    std::error_code error;
    std::filesystem::create_directories(options.frames, error);
    if (error || !std::filesystem::is_directory(options.frames)) {
      throw Error("--frames " + options.frames.string() + ": cannot make the folder (" + error.message() + ")",
                  "give a folder that exists or can be created");
    }
  }
  if (!options.video.empty()) m_video = std::make_unique<VideoEncoder>(options.video, options.width, options.height, options.fps);
  m_context = render::create_headless_context(options.backend);
  m_description = std::string(render::to_string(options.backend)) + ": " + m_context->description();
  log_info("rendering " + std::to_string(options.width) + "×" + std::to_string(options.height) + " at " +
           std::to_string(options.fps) + " frames/s with " + m_description);
  m_renderer = std::make_unique<render::Renderer>(options.width, options.height);
  m_renderer->set_walls_visible(options.walls);
  m_renderer->set_normal_mapping(options.normal_mapping);
  m_renderer->set_fragment_colors(options.fragment_colors);
  m_renderer->set_cage_visible(options.cage);
  m_renderer->set_spheres_visible(options.spheres);
  m_renderer->set_replication_colors(options.replication_colors);
  m_renderer->set_tessellation(options.tessellation);
  m_view = std::make_unique<SceneView>(scene.world, scene.assets, *m_renderer, scene.camera);
}

FrameOutput::~FrameOutput() = default;

void FrameOutput::capture(const sim::World& world, int steps, double physics_ms) {
  FrameRecord record{world.time(), steps, physics_ms, 0, 0, 0};
  auto start = Clock::now();
  m_view->update(world);
  m_renderer->render(m_pixels);
  record.render_ms = ms_since(start);
  record.upload_bytes = m_renderer->last_stats().upload_bytes;
  start = Clock::now();
  if (!m_options.frames.empty()) {
    formats::write_png(m_options.frames / frame_name(m_records.size()),
                       {m_renderer->width(), m_renderer->height(), m_pixels});
  }
  if (m_video) m_video->add(m_pixels);
  record.output_ms = ms_since(start);
  m_records.push_back(record);
}

void FrameOutput::finish() {
  if (m_video) m_video->finish();
  if (m_options.frames.empty()) return;
  JsonWriter json;
  json.begin_object();
  json.key("renderer").value(m_description);
  json.key("width").value(m_options.width);
  json.key("height").value(m_options.height);
  json.key("fps").value(m_options.fps);
  json.key("frames").begin_array();
  for (std::size_t i = 0; i < m_records.size(); ++i) {
    const FrameRecord& r = m_records[i];
    json.begin_object();
    json.key("file").value(frame_name(i));
    json.key("time_s").value(r.time);
    json.key("steps").value(r.steps);
    json.key("physics_ms").value(r.physics_ms);
    json.key("render_ms").value(r.render_ms);
    json.key("output_ms").value(r.output_ms);
    json.key("upload_bytes").value(static_cast<std::uint64_t>(r.upload_bytes));
    json.end_object();
  }
  json.end_array();
  json.end_object();
  write_file_atomically(m_options.frames / "frames.json", json.str() + "\n");
}

}  // namespace fissure::player
