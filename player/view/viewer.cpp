#include "player/view/viewer.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>

#include "common/error.h"
#include "common/log.h"
#include "formats/image.h"
#include "formats/trajectory.h"
#include "player/app/replay.h"
#include "player/app/scene_loader.h"
#include "player/app/scene_view.h"
#include "player/render/window.h"
#include "player/view/orbit_camera.h"
#include "player/view/panel.h"
#include "player/view/view_script.h"

namespace fissure::view {

namespace {

using Clock = std::chrono::steady_clock;

/// A mouse press that moves less than this before release is a click (a shot), not a drag.
constexpr double kClickSlop = 4.0;  // screen pixels
/// The longest frame the clock lets through, so a stall (a breakpoint, a slow step)
/// never sends the world a huge step of catch-up.
constexpr double kMaxFrameSeconds = 0.1;

class Viewer {
 public:
  Viewer(const formats::Scene& scene, const ViewOptions& options);
  int run();

 private:
  void reset();
  void handle_input();
  void on_key(int key);
  void fire(float x, float y);
  /// One script action (or one frame of a wait); false when the script asks to quit.
  bool script_step();
  void advance(double frame_seconds);
  /// A replay's clock: real time (scaled), or frames per frame, or the timeline.
  void advance_replay(double frame_seconds);
  void seek(long frame);
  void take_steps(long steps);
  void draw();
  void apply_features();
  void set_material(std::size_t body, const sim::Material& material, double toughness);
  bool write_screenshot(const std::filesystem::path& path);
  [[nodiscard]] std::pair<int, int> framebuffer_size() const { return m_window.framebuffer_size(); }

  formats::Scene m_scene;
  ViewOptions m_options;
  render::Window m_window;
  std::unique_ptr<render::UiLayer> m_ui;
  // The session: remade by reset().
  std::unique_ptr<player::LoadedScene> m_loaded;
  std::unique_ptr<render::Renderer> m_renderer;
  std::unique_ptr<player::SceneView> m_view;
  std::unique_ptr<player::RunLoop> m_loop;
  std::unique_ptr<StepHistory> m_history;
  std::optional<formats::Trajectory> m_trajectory;  ///< --replay's, read once
  std::unique_ptr<player::Replay> m_replay;
  double m_replay_time = 0;  ///< [s] where the replay's clock is
  std::optional<OrbitCamera> m_camera;  ///< set once the user moves the camera
  PanelState m_panel;
  // The clock and the script.
  std::vector<ScriptAction> m_script;
  std::size_t m_next_action = 0;
  long m_wait_frames = 0;
  long m_frames = 0;
  bool m_quit = false, m_failed = false;
  std::vector<std::uint8_t> m_pixels;
  // The mouse: where a press began, and the last position.
  bool m_dragging = false, m_drag_moved = false;
  double m_press_x = 0, m_press_y = 0, m_last_x = 0, m_last_y = 0;
  int m_drag_button = -1;
  float m_scroll = 0;
};

Viewer::Viewer(const formats::Scene& scene, const ViewOptions& options)
    : m_scene(scene), m_options(options), m_window("fissure-player — " + scene.file.filename().string(), options.width, options.height) {
  if (!options.script.empty()) m_script = read_script(options.script);
  if (!options.replay.empty()) m_trajectory = formats::read_trajectory(options.replay);
  // Our callbacks first: ImGui's backend chains to them, then takes what it wants.
  glfwSetWindowUserPointer(m_window.handle(), this);
  glfwSetScrollCallback(m_window.handle(), [](GLFWwindow* w, double /*dx*/, double dy) {
    static_cast<Viewer*>(glfwGetWindowUserPointer(w))->m_scroll += static_cast<float>(dy);
  });
  glfwSetKeyCallback(m_window.handle(), [](GLFWwindow* w, int key, int /*scancode*/, int action, int /*mods*/) {
    if (action == GLFW_PRESS || action == GLFW_REPEAT) static_cast<Viewer*>(glfwGetWindowUserPointer(w))->on_key(key);
  });
  m_ui = std::make_unique<render::UiLayer>(m_window);
  m_panel.paused = options.paused;
  m_panel.steps_per_frame = options.steps_per_frame;
  m_panel.tessellation_level = options.tessellation;
  reset();
}

void Viewer::reset() {
  m_view.reset();
  m_renderer.reset();
  m_loop.reset();
  m_loaded = std::make_unique<player::LoadedScene>(player::load_scene(m_scene));
  const auto [width, height] = framebuffer_size();
  m_renderer = std::make_unique<render::Renderer>(std::max(width, 1), std::max(height, 1));
  apply_features();
  m_view = std::make_unique<player::SceneView>(m_loaded->world, m_loaded->assets, *m_renderer, m_loaded->camera);
  if (m_camera) m_view->set_camera(m_camera->camera());
  m_history = std::make_unique<StepHistory>();
  m_loop = std::make_unique<player::RunLoop>(m_loaded->world);
  m_loop->add(*m_history);
  m_loop->start();
  m_panel.status.clear();
  m_failed = false;
  m_panel.bodies.clear();
  for (const sim::Body& b : m_loaded->world.bodies()) {
    m_panel.bodies.push_back({b.name, b.integrator().material(), b.fracture.toughness});
  }
  m_panel.settings = m_loaded->world.settings();
  if (m_trajectory) {
    m_replay = std::make_unique<player::Replay>(*m_trajectory, m_options.replay.string(), m_loaded->world);
    m_panel.replay.frames = m_replay->frame_count();
    // To the end and back: every recorded split is checked against the scene now, so
    // scrubbing later cannot fail.
    seek(static_cast<long>(m_replay->frame_count()) - 1);
    seek(0);
  }
}

void Viewer::seek(long frame) {
  const long last = static_cast<long>(m_replay->frame_count()) - 1;
  m_replay->seek(m_loaded->world, static_cast<std::size_t>(std::clamp(frame, 0L, last)));
  m_replay_time = m_replay->time(m_replay->frame());
  m_panel.replay.frame = static_cast<int>(m_replay->frame());
  m_panel.replay.step = static_cast<long>(m_replay->step(m_replay->frame()));
  m_history->splits = static_cast<long>(m_replay->applied_splits());
}

void Viewer::apply_features() {
  const Features& f = m_panel.features;
  m_renderer->set_walls_visible(f.walls);
  m_renderer->set_normal_mapping(f.normal_mapping);
  m_renderer->set_tessellation(f.tessellation ? m_panel.tessellation_level : 0.0f);
  m_renderer->set_cage_visible(f.cage);
  m_renderer->set_spheres_visible(f.spheres);
  m_renderer->set_replication_colors(f.replication_colors);
  m_renderer->set_fragment_colors(f.fragment_colors);
}

void Viewer::on_key(int key) {
  if (m_ui->wants_keyboard()) return;
  switch (key) {
    case GLFW_KEY_SPACE: m_panel.paused = !m_panel.paused; break;
    case GLFW_KEY_N:
    case GLFW_KEY_RIGHT: m_panel.pending_steps += 1; break;
    case GLFW_KEY_LEFT:  // a replay's frame back; a simulation cannot step back
      if (m_replay) m_panel.pending_steps -= 1;
      break;
    case GLFW_KEY_R: m_panel.reset_requested = true; break;
    case GLFW_KEY_F:  // back to the scene's own framing (following the bodies); the world goes on
      m_camera.reset();
      m_view->restore_camera();
      break;
    case GLFW_KEY_P: m_panel.screenshot_requested = true; break;
    case GLFW_KEY_H: m_options.panel = !m_options.panel; break;
    case GLFW_KEY_ESCAPE: m_quit = true; break;
    default: break;
  }
}

void Viewer::handle_input() {
  double x = 0, y = 0;
  glfwGetCursorPos(m_window.handle(), &x, &y);
  const auto [fb_width, fb_height] = framebuffer_size();
  int win_width = 1, win_height = 1;
  glfwGetWindowSize(m_window.handle(), &win_width, &win_height);
  const bool free_mouse = !m_ui->wants_mouse();
  const auto pressed = [&](int b) { return glfwGetMouseButton(m_window.handle(), b) == GLFW_PRESS; };
  if (!m_dragging && free_mouse) {
    for (const int b : {GLFW_MOUSE_BUTTON_LEFT, GLFW_MOUSE_BUTTON_RIGHT, GLFW_MOUSE_BUTTON_MIDDLE}) {
      if (!pressed(b)) continue;
      m_dragging = true;
      m_drag_moved = false;
      m_drag_button = b;
      m_press_x = m_last_x = x;
      m_press_y = m_last_y = y;
      break;
    }
  }
  if (m_dragging) {
    const double dx = x - m_last_x, dy = y - m_last_y;
    if (std::hypot(x - m_press_x, y - m_press_y) > kClickSlop) m_drag_moved = true;
    if (m_drag_moved && (dx != 0 || dy != 0)) {
      if (!m_camera) m_camera.emplace(m_view->camera());
      const bool pan = m_drag_button != GLFW_MOUSE_BUTTON_LEFT ||
                       glfwGetKey(m_window.handle(), GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS;
      if (pan) {
        m_camera->pan(static_cast<float>(dx), static_cast<float>(dy), win_height);
      } else {
        m_camera->orbit(static_cast<float>(dx), static_cast<float>(dy));
      }
      m_view->set_camera(m_camera->camera());
    }
    m_last_x = x;
    m_last_y = y;
    if (!pressed(m_drag_button)) {
      m_dragging = false;
      // A left click that did not drag fires, through the pixel under the cursor.
      if (!m_drag_moved && m_drag_button == GLFW_MOUSE_BUTTON_LEFT) {
        fire(static_cast<float>(x * fb_width / std::max(win_width, 1)), static_cast<float>(y * fb_height / std::max(win_height, 1)));
      }
    }
  }
  if (m_scroll != 0 && free_mouse) {
    if (!m_camera) m_camera.emplace(m_view->camera());
    m_camera->zoom(m_scroll);
    m_view->set_camera(m_camera->camera());
  }
  m_scroll = 0;
}

void Viewer::fire(float x, float y) {
  if (m_replay) {
    m_panel.status = "a replay shows the recorded run: shots are off (view the scene without --replay to shoot)";
    return;
  }
  const auto [width, height] = framebuffer_size();
  const OrbitCamera aim = m_camera ? *m_camera : OrbitCamera(m_view->camera());
  const Ray ray = aim.ray(x, y, width, height);
  sim::Projectile p;
  p.position = ray.origin.cast<double>();
  p.velocity = static_cast<double>(m_panel.shot.speed) * ray.direction.cast<double>();
  p.radius = m_panel.shot.radius;
  p.mass = m_panel.shot.mass;
  m_loaded->world.add_projectile(p);  // update() draws it from the next frame on
  ++m_panel.shots;
}

void Viewer::set_material(std::size_t body, const sim::Material& material, double toughness) {
  try {
    m_loaded->world.set_material(static_cast<Index>(body), material, toughness);
    m_panel.bodies[body].material = material;
    m_panel.bodies[body].toughness = toughness;
  } catch (const Error& e) {
    m_panel.status = e.what();
  }
}

bool Viewer::write_screenshot(const std::filesystem::path& path) {
  try {
    m_renderer->read(m_pixels);
    formats::write_png(path, {m_renderer->width(), m_renderer->height(), m_pixels});
    log_info("screenshot " + path.string());
    return true;
  } catch (const Error& e) {
    m_panel.status = e.what();
    std::fputs(format_error(e).c_str(), stderr);
    return false;
  }
}

bool Viewer::script_step() {
  if (m_wait_frames > 0) {
    --m_wait_frames;
    return true;
  }
  if (m_next_action >= m_script.size()) return true;
  const ScriptAction& a = m_script[m_next_action++];
  const std::string where = m_options.script.string() + ":" + std::to_string(a.line);
  using Kind = ScriptAction::Kind;
  switch (a.kind) {
    case Kind::Wait: m_wait_frames = a.count - 1; break;
    case Kind::Pause: m_panel.paused = true; break;
    case Kind::Resume: m_panel.paused = false; break;
    case Kind::Step: m_panel.pending_steps += a.count; break;
    case Kind::Seek:
      if (!m_replay) throw Error(where + ": seek needs a replay", "open the scene with --replay TRAJECTORY");
      seek(a.count);
      break;
    case Kind::Fire: fire(a.x, a.y); break;
    case Kind::Shot: m_panel.shot = {a.mass, a.radius, a.speed}; break;
    case Kind::Toggle: {
      bool* feature = m_panel.features.find(a.name);
      *feature = !*feature;
      apply_features();
      break;
    }
    case Kind::Set: {
      if (m_replay) throw Error(where + ": a replay's materials are the recorded run's", "leave out --replay to tune them");
      const auto& bodies = m_loaded->world.bodies();
      std::size_t b = 0;
      while (b < bodies.size() && bodies[b].name != a.name) ++b;
      if (b == bodies.size()) throw Error(where + ": the scene has no object named '" + a.name + "'", "use an [[object]]'s name");
      sim::Material m = m_panel.bodies[b].material;
      double toughness = m_panel.bodies[b].toughness;
      if (a.parameter == "youngs_modulus") m.youngs_modulus = a.value;
      if (a.parameter == "poisson_ratio") m.poisson_ratio = a.value;
      if (a.parameter == "density") m.density = a.value;
      if (a.parameter == "damping") m.rayleigh_mass = a.value;
      if (a.parameter == "toughness") toughness = a.value;
      m_loaded->world.set_material(static_cast<Index>(b), m, toughness);  // a bad value fails the script
      m_panel.bodies[b] = {a.name, m, toughness};
      break;
    }
    case Kind::Screenshot: m_panel.screenshot_path = a.name; break;
    case Kind::Quit: return false;
  }
  return true;
}

void Viewer::take_steps(long steps) {
  if (steps <= 0 || m_failed) return;
  m_loop->take_steps(steps);
}

void Viewer::advance_replay(double frame_seconds) {
  long frame = static_cast<long>(m_replay->frame());
  if (!m_panel.paused) {
    if (m_panel.steps_per_frame > 0) {
      frame += m_panel.steps_per_frame;
    } else {
      m_replay_time += std::min(frame_seconds, kMaxFrameSeconds) * m_panel.time_scale;
      frame = static_cast<long>(m_replay->frame_at(m_replay_time));
    }
  }
  const long pending = std::exchange(m_panel.pending_steps, 0);
  frame += pending;
  const double clock = m_replay_time;
  if (frame != static_cast<long>(m_replay->frame())) seek(frame);
  // Playing in real time, the clock runs on between recorded frames; a seek sets it.
  if (!m_panel.paused && m_panel.steps_per_frame == 0 && pending == 0) m_replay_time = clock;
  if (m_replay->frame() + 1 == m_replay->frame_count() && !m_panel.paused) {
    m_panel.paused = true;  // the end of the recording: stay on its last frame
  }
}

void Viewer::advance(double frame_seconds) {
  if (m_replay) return advance_replay(frame_seconds);
  if (m_failed) return;
  if (!m_panel.paused) {
    if (m_panel.steps_per_frame > 0) {
      take_steps(m_panel.steps_per_frame);
    } else {
      m_loop->advance(std::min(frame_seconds, kMaxFrameSeconds) * m_panel.time_scale, 8);
    }
  }
  take_steps(std::exchange(m_panel.pending_steps, 0));
  if (m_loop->stopped()) {
    // The world is as it was before the failed step: pause and say why.
    const player::RunEnd& end = m_loop->end();
    const sim::StepFailure failure =
        end.stop ? sim::StepFailure{end.stop->message, end.stop->hint} : m_loaded->world.explain(end.status);
    m_panel.status = failure.message + " (" + failure.hint + "); press R to reset";
    m_panel.paused = m_failed = true;
    log_warning(m_panel.status);
  }
}

void Viewer::draw() {
  const auto [width, height] = framebuffer_size();
  if (width < 1 || height < 1) return;  // minimised
  m_renderer->resize(width, height);
  m_view->update(m_loaded->world);
  m_renderer->draw();
  m_panel.render_ms.push_back(static_cast<float>(m_renderer->last_stats().draw_ms));
  if (m_panel.render_ms.size() > StepHistory::kLength) m_panel.render_ms.pop_front();
  if (!m_panel.screenshot_path.empty()) {
    if (!write_screenshot(m_panel.screenshot_path)) m_panel.script_failed = true;
    m_panel.screenshot_path.clear();
  }
  if (m_panel.screenshot_requested) {
    char name[64];
    std::snprintf(name, sizeof name, "fissure-screenshot-%03d.png", m_panel.screenshots++);
    write_screenshot(name);
    m_panel.screenshot_requested = false;
  }
  m_renderer->present(width, height);
  m_ui->begin_frame();
  if (m_options.panel) {
    const PanelEdits edits = draw_panel(m_panel, m_loaded->world, *m_history);
    if (edits.features) apply_features();
    if (edits.seek) seek(m_panel.replay.frame);
    if (edits.settings) {
      try {
        m_loaded->world.set_settings(m_panel.settings);
      } catch (const Error& e) {
        m_panel.status = e.what();
      }
    }
    if (edits.body) set_material(*edits.body, m_panel.bodies[*edits.body].material, m_panel.bodies[*edits.body].toughness);
  }
  m_ui->end_frame();
  m_window.swap_buffers();
}

int Viewer::run() {
  auto last = Clock::now();
  while (!m_window.should_close() && !m_quit) {
    render::Window::poll_events();
    handle_input();
    if (!script_step()) break;
    if (m_panel.reset_requested) {
      m_panel.reset_requested = false;
      reset();
    }
    const auto now = Clock::now();
    advance(std::chrono::duration<double>(now - last).count());
    last = now;
    draw();
    ++m_frames;
    if (m_options.exit_after_frames > 0 && m_frames >= m_options.exit_after_frames) break;
  }
  bool ok = !m_panel.script_failed;
  if (!m_options.screenshot.empty()) ok = write_screenshot(m_options.screenshot) && ok;
  std::printf("view       %ld frames, %ld steps, t = %.4f s, %ld fragments, %d shots\n", m_frames, m_history->steps,
              m_loaded->world.time(), static_cast<long>(m_loaded->world.fragment_count()), m_panel.shots);
  if (m_replay) {
    std::printf("replay     frame %zu of %zu (step %llu) of %s\n", m_replay->frame(), m_replay->frame_count(),
                static_cast<unsigned long long>(m_replay->step(m_replay->frame())), m_replay->file().c_str());
  }
  if (m_failed) std::printf("status     %s\n", m_panel.status.c_str());
  return ok ? 0 : 1;
}

}  // namespace

int view_scene(const formats::Scene& scene, const ViewOptions& options) {
  Viewer viewer(scene, options);
  return viewer.run();
}

}  // namespace fissure::view
