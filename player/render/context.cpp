#include "player/render/context.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <glad/gl.h>
// After glad: osmesa.h includes GL/gl.h, whose declarations glad's header replaces.
#include <GL/osmesa.h>

#include <cstdio>
#include <vector>

#include "common/error.h"

namespace fissure::render {

namespace {

void load_gl(GLADloadfunc load, const char* backend) {
  if (gladLoadGL(load) == 0) {
    throw Error(std::string(backend) + ": could not load the OpenGL 4.5 core functions",
                "check the Mesa drivers (libgl1-mesa-dri) are installed");
  }
}

class OSMesaBackend : public Context {
 public:
  OSMesaBackend() {
    const int attributes[] = {OSMESA_FORMAT,       OSMESA_RGBA, OSMESA_DEPTH_BITS, 24, OSMESA_PROFILE,
                              OSMESA_CORE_PROFILE, OSMESA_CONTEXT_MAJOR_VERSION, 4, OSMESA_CONTEXT_MINOR_VERSION,
                              5, 0};
    m_context = OSMesaCreateContextAttribs(attributes, nullptr);
    if (m_context == nullptr) {
      throw Error("OSMesa could not create an OpenGL 4.5 core context",
                  "install libosmesa6 (Mesa ≥ 20), or use --backend egl");
    }
    // A constructor that throws runs no destructor: the context is freed here.
    try {
      make_current();
    } catch (...) {
      OSMesaDestroyContext(m_context);
      throw;
    }
  }
  ~OSMesaBackend() override { OSMesaDestroyContext(m_context); }
  OSMesaBackend(const OSMesaBackend&) = delete;
  OSMesaBackend& operator=(const OSMesaBackend&) = delete;

  void make_current() override {
    // OSMesa needs a colour buffer to be current; the renderer draws into its own FBO.
    if (!OSMesaMakeCurrent(m_context, m_buffer.data(), GL_UNSIGNED_BYTE, kSide, kSide)) {
      throw Error("OSMesa could not make its context current", "use --backend egl");
    }
    load_gl(reinterpret_cast<GLADloadfunc>(OSMesaGetProcAddress), "OSMesa");
  }

 private:
  static constexpr int kSide = 4;
  OSMesaContext m_context = nullptr;
  std::vector<unsigned char> m_buffer = std::vector<unsigned char>(4 * kSide * kSide);
};

class EglBackend : public Context {
 public:
  EglBackend() {
    m_display = open_display();
    if (!eglBindAPI(EGL_OPENGL_API)) fail("desktop OpenGL is not available");
    // No config: the context draws only into the renderer's FBO (EGL_KHR_no_config_context;
    // the surfaceless platform may offer no config with a surface type at all).
    const EGLConfig config = EGL_NO_CONFIG_KHR;
    const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                                         EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                         EGL_NONE};
    m_context = eglCreateContext(m_display, config, EGL_NO_CONTEXT, context_attributes);
    if (m_context == EGL_NO_CONTEXT) fail("no OpenGL 4.5 core context");
    // A constructor that throws runs no destructor: the context is released here.
    try {
      make_current();
    } catch (...) {
      release();
      throw;
    }
  }
  ~EglBackend() override { release(); }
  EglBackend(const EglBackend&) = delete;
  EglBackend& operator=(const EglBackend&) = delete;

  void make_current() override {
    if (!eglMakeCurrent(m_display, EGL_NO_SURFACE, EGL_NO_SURFACE, m_context)) fail("eglMakeCurrent failed");
    load_gl(reinterpret_cast<GLADloadfunc>(eglGetProcAddress), "EGL");
  }

 private:
  /// Mesa's surfaceless platform where it exists (any Mesa driver, llvmpipe included);
  /// else the first EGL device (EGL_EXT_platform_device): NVIDIA's driver offers only
  /// that one for drawing without a window system.
  EGLDisplay open_display() {
    const auto get_platform_display =
        reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (get_platform_display == nullptr) fail("eglGetPlatformDisplayEXT is missing");
    EGLDisplay display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display != EGL_NO_DISPLAY && eglInitialize(display, nullptr, nullptr)) return display;
    const auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    EGLDeviceEXT device = nullptr;
    EGLint devices = 0;
    if (query_devices == nullptr || !query_devices(1, &device, &devices) || devices < 1) {
      fail("neither a surfaceless display nor an EGL device");
    }
    display = get_platform_display(EGL_PLATFORM_DEVICE_EXT, device, nullptr);
    if (display == EGL_NO_DISPLAY || !eglInitialize(display, nullptr, nullptr)) fail("the EGL device has no display");
    return display;
  }

  void release() {
    eglMakeCurrent(m_display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (m_context != EGL_NO_CONTEXT) eglDestroyContext(m_display, m_context);
    m_context = EGL_NO_CONTEXT;
    eglReleaseThread();
    // No eglTerminate: the display is shared by the whole process (EGL hands
    // every caller the same one), and terminating it lets libglvnd unload Mesa's driver,
    // which leaves its caches unattributable to LeakSanitizer. The driver goes at exit.
  }

  [[noreturn]] void fail(const std::string& what) {
    if (m_display != EGL_NO_DISPLAY) eglTerminate(m_display);
    throw Error("EGL: " + what + " (EGL error 0x" + hex(eglGetError()) + ")",
                "install libegl-mesa0 and libgl1-mesa-dri, or use --backend osmesa");
  }
  static std::string hex(EGLint code) {
    char text[16];
    std::snprintf(text, sizeof text, "%x", static_cast<unsigned>(code));
    return text;
  }

  EGLDisplay m_display = EGL_NO_DISPLAY;
  EGLContext m_context = EGL_NO_CONTEXT;
};

}  // namespace

const char* to_string(Backend backend) { return backend == Backend::OSMesa ? "osmesa" : "egl"; }

Backend parse_backend(const std::string& name) {
  if (name == "osmesa") return Backend::OSMesa;
  if (name == "egl") return Backend::Egl;
  throw Error("unknown render backend '" + name + "'", "use --backend osmesa or --backend egl");
}

std::string Context::description() const {
  const auto text = [](GLenum name) {
    const auto* s = reinterpret_cast<const char*>(glGetString(name));
    return std::string(s != nullptr ? s : "?");
  };
  return text(GL_RENDERER) + ", OpenGL " + text(GL_VERSION);
}

std::unique_ptr<Context> create_headless_context(Backend backend) {
  if (backend == Backend::OSMesa) return std::make_unique<OSMesaBackend>();
  return std::make_unique<EglBackend>();
}

}  // namespace fissure::render
