#pragma once
/// `run --frames/--video`: a headless GL context, the renderer and the scene's view,
/// and where the images go (PNG files, an H.264 video, or both), with a record per
/// frame of what it cost. Nothing of it exists in a run that asks for no images.

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "player/app/scene_loader.h"
#include "player/app/scene_view.h"
#include "player/app/video_encoder.h"
#include "player/render/context.h"
#include "player/render/renderer.h"

namespace fissure::player {

struct FrameOptions {
  std::filesystem::path frames;  ///< folder for frame-NNNNN.png and frames.json; empty: none
  std::filesystem::path video;   ///< .mp4; empty: none
  int width = 1280, height = 720;
  int fps = 30;
  render::Backend backend = render::Backend::OSMesa;
  bool walls = true;             ///< draw the walls fracture opens
  bool normal_mapping = true;    ///< detail normals on the walls
  bool fragment_colors = false;  ///< debug view: a colour per fragment
  bool cage = false;             ///< debug view: the cage's edges
  bool spheres = false;          ///< debug view: the collision spheres in place of the surface
  bool replication_colors = false;  ///< debug view: triangles by how many tets they are drawn in
  /// Tessellated relief on interior walls: the most segments per wall edge (≤ 1: off).
  /// Off by default: within the bake's clearance the relief changes few pixels at the
  /// distances scenes are framed from (22 of 540,000 on the fully shattered bunny) for
  /// up to 2× the wall cost (BENCHMARKS.md); 8 is enough close up.
  float tessellation = 0.0f;
  [[nodiscard]] bool wanted() const { return !frames.empty() || !video.empty(); }
};

/// "1280x720" → {1280, 720}; throws fissure::Error naming the option otherwise.
std::pair<int, int> parse_size(const std::string& text);

struct FrameRecord {
  double time = 0;           ///< simulation time [s]
  int steps = 0;             ///< physics steps taken for this frame
  double physics_ms = 0;     ///< their wall time
  double render_ms = 0;      ///< drawing and reading back
  double output_ms = 0;      ///< PNG encoding and/or handing to ffmpeg
  std::size_t upload_bytes = 0;
};

class FrameOutput {
 public:
  /// Creates the folder, the context (throws fissure::Error when the backend cannot)
  /// and the view of `scene`.
  FrameOutput(const FrameOptions& options, const LoadedScene& scene);
  ~FrameOutput();

  /// Renders the world as it is now and writes the frame.
  void capture(const sim::World& world, int steps, double physics_ms);
  /// Finishes the video and writes frames.json. Throws fissure::Error on failure.
  void finish();

  [[nodiscard]] const std::vector<FrameRecord>& records() const { return m_records; }
  [[nodiscard]] std::string renderer_description() const { return m_description; }

 private:
  FrameOptions m_options;
  std::unique_ptr<render::Context> m_context;
  std::unique_ptr<render::Renderer> m_renderer;
  std::unique_ptr<SceneView> m_view;
  std::unique_ptr<VideoEncoder> m_video;
  std::vector<std::uint8_t> m_pixels;
  std::vector<FrameRecord> m_records;
  std::string m_description;
};

}  // namespace fissure::player
