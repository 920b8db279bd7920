#include "player/render/window.h"

#include <glad/gl.h>
// After glad: GLFW must not include a GL header of its own.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

#include <string>

#include "common/error.h"

namespace fissure::render {

namespace {

std::string g_last_glfw_error;

void remember_glfw_error(int /*code*/, const char* description) { g_last_glfw_error = description; }

/// GLFW is initialised once per process and lives until its end (a window may be
/// reopened: a viewer's reset keeps its window, tests open several).
void init_glfw() {
  static const bool ok = [] {
    glfwSetErrorCallback(remember_glfw_error);
    return glfwInit() == GLFW_TRUE;
  }();
  if (!ok) {
    throw Error("cannot open a window: no display (" + g_last_glfw_error + ")",
                "run it on a desktop, or under `xvfb-run -a`; for images without a window use "
                "`fissure-player run SCENE --frames DIR`");
  }
}

}  // namespace

Window::Window(const std::string& title, int width, int height) {
  init_glfw();
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  m_window = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
  if (m_window == nullptr) {
    throw Error("cannot open a " + std::to_string(width) + "×" + std::to_string(height) +
                    " window with OpenGL 4.5 core (" + g_last_glfw_error + ")",
                "check the display's OpenGL (`glxinfo -B`), or use `fissure-player run SCENE --frames DIR`");
  }
  make_current();
  glfwSwapInterval(1);
}

Window::~Window() { glfwDestroyWindow(m_window); }

void Window::make_current() {
  glfwMakeContextCurrent(m_window);
  if (gladLoadGL(reinterpret_cast<GLADloadfunc>(glfwGetProcAddress)) == 0) {
    throw Error("the window's context could not load the OpenGL 4.5 core functions",
                "check the display's OpenGL (`glxinfo -B`)");
  }
}

std::pair<int, int> Window::framebuffer_size() const {
  int width = 0, height = 0;
  glfwGetFramebufferSize(m_window, &width, &height);
  return {width, height};
}

bool Window::should_close() const { return glfwWindowShouldClose(m_window) == GLFW_TRUE; }
void Window::swap_buffers() { glfwSwapBuffers(m_window); }
void Window::poll_events() { glfwPollEvents(); }

UiLayer::UiLayer(Window& window) {
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini left in the user's folder
  ImGui::StyleColorsDark();
  // install_callbacks: ImGui chains to callbacks installed before it.
  ImGui_ImplGlfw_InitForOpenGL(window.handle(), true);
  ImGui_ImplOpenGL3_Init("#version 450 core");
}

UiLayer::~UiLayer() {
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
}

void UiLayer::begin_frame() {
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
}

void UiLayer::end_frame() {
  ImGui::Render();
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
}

bool UiLayer::wants_mouse() const { return ImGui::GetIO().WantCaptureMouse; }
bool UiLayer::wants_keyboard() const { return ImGui::GetIO().WantCaptureKeyboard; }

}  // namespace fissure::render
