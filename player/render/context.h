#pragma once
/// Headless OpenGL 4.5 core contexts (docs/architecture.md, "The sim/render boundary"). A
/// backend only makes the context current and loads GL's functions; the renderer draws
/// into its own FBO, so every backend gives the same image.
///  - OSMesa: Mesa's off-screen library, software (llvmpipe); the default on Debian 12.
///  - EGL without a window system: Mesa's surfaceless platform (no display, no /dev/dri;
///    llvmpipe here), else the first EGL device (EGL_EXT_platform_device: NVIDIA's
///    driver on a GPU machine). OSMesa is gone from Mesa 25.1.
/// The window (GLFW) is a third backend, in the viewer.

#include <memory>
#include <string>

namespace fissure::render {

enum class Backend { OSMesa, Egl };

[[nodiscard]] const char* to_string(Backend backend);
/// "osmesa" or "egl"; throws fissure::Error naming the choices otherwise.
[[nodiscard]] Backend parse_backend(const std::string& name);

class Context {
 public:
  virtual ~Context() = default;
  /// Makes this context current on the calling thread and (re)loads GL's functions.
  virtual void make_current() = 0;
  /// GL_RENDERER and GL_VERSION, for reports.
  [[nodiscard]] std::string description() const;
};

/// A current GL 4.5 core context. Throws fissure::Error (saying which backend failed and
/// what to try) when the backend cannot make one.
std::unique_ptr<Context> create_headless_context(Backend backend);

}  // namespace fissure::render
