#pragma once
/// The renderer's third backend (docs/architecture.md, "The sim/render boundary"): a GLFW
/// window with a GL 4.5 core context, and a Dear ImGui layer drawn over it. The renderer
/// still draws into its own framebuffer; the window shows it with Renderer::present(), so
/// a window and a headless context give the same image.

#include <memory>
#include <string>

#include "player/render/context.h"

struct GLFWwindow;

namespace fissure::render {

class Window : public Context {
 public:
  /// Opens a window of `width` × `height` screen pixels. Throws fissure::Error with a
  /// hint when there is no display (use `run --frames` there) or no GL 4.5 core.
  Window(const std::string& title, int width, int height);
  ~Window() override;
  Window(const Window&) = delete;
  Window& operator=(const Window&) = delete;

  void make_current() override;
  [[nodiscard]] GLFWwindow* handle() const { return m_window; }
  /// Its drawable size in pixels (may differ from the window's on a high-DPI screen).
  [[nodiscard]] std::pair<int, int> framebuffer_size() const;
  [[nodiscard]] bool should_close() const;
  void swap_buffers();
  /// Handles the window system's events (input, resize, close); callbacks run inside.
  static void poll_events();

 private:
  GLFWwindow* m_window = nullptr;
};

/// Dear ImGui on a window: begin_frame() before any ImGui call of a frame, end_frame()
/// after, with the window's default framebuffer bound (after Renderer::present()).
class UiLayer {
 public:
  explicit UiLayer(Window& window);
  ~UiLayer();
  UiLayer(const UiLayer&) = delete;
  UiLayer& operator=(const UiLayer&) = delete;

  void begin_frame();
  void end_frame();
  /// Whether ImGui uses the mouse or keyboard now (over the panel, typing in a field):
  /// then the scene must not take the input too.
  [[nodiscard]] bool wants_mouse() const;
  [[nodiscard]] bool wants_keyboard() const;
};

}  // namespace fissure::render
