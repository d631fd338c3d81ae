#include "render/EglContext.hpp"

#include "core/Error.hpp"

#include <epoxy/egl.h>
#include <epoxy/gl.h>

#include <string>
#include <vector>

namespace kf::render {

namespace {

std::string egl_error() {
  const EGLint e = eglGetError();
  switch (e) {
  case EGL_SUCCESS:
    return "EGL_SUCCESS";
  case EGL_NOT_INITIALIZED:
    return "EGL_NOT_INITIALIZED";
  case EGL_BAD_ACCESS:
    return "EGL_BAD_ACCESS";
  case EGL_BAD_ALLOC:
    return "EGL_BAD_ALLOC";
  case EGL_BAD_ATTRIBUTE:
    return "EGL_BAD_ATTRIBUTE";
  case EGL_BAD_CONFIG:
    return "EGL_BAD_CONFIG";
  case EGL_BAD_CONTEXT:
    return "EGL_BAD_CONTEXT";
  case EGL_BAD_DISPLAY:
    return "EGL_BAD_DISPLAY";
  case EGL_BAD_MATCH:
    return "EGL_BAD_MATCH";
  case EGL_BAD_PARAMETER:
    return "EGL_BAD_PARAMETER";
  default:
    return "EGL error " + std::to_string(e);
  }
}

/// A display initialised and bound to the OpenGL API with a 4.5 core context on it, or none
/// (why: appended to `tried`).
struct Opened {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
};

Opened open_on(EGLDisplay dpy, const std::string& what, std::string& tried) {
  Opened o;
  if (dpy == EGL_NO_DISPLAY) {
    tried += "\n  " + what + ": no display (" + egl_error() + ")";
    return o;
  }
  EGLint major = 0, minor = 0;
  if (!eglInitialize(dpy, &major, &minor)) {
    tried += "\n  " + what + ": eglInitialize failed (" + egl_error() + ")";
    return o;
  }
  if (!eglBindAPI(EGL_OPENGL_API)) {
    tried += "\n  " + what + ": no desktop OpenGL (" + egl_error() + ")";
    eglTerminate(dpy);
    return o;
  }
  // No surface: rendering goes to framebuffer objects (EGL_KHR_surfaceless_context).
  const EGLint config_attribs[] = {EGL_SURFACE_TYPE,
                                   EGL_PBUFFER_BIT,
                                   EGL_RENDERABLE_TYPE,
                                   EGL_OPENGL_BIT,
                                   EGL_RED_SIZE,
                                   8,
                                   EGL_GREEN_SIZE,
                                   8,
                                   EGL_BLUE_SIZE,
                                   8,
                                   EGL_NONE};
  EGLConfig config = nullptr;
  EGLint configs = 0;
  const bool any_config = eglChooseConfig(dpy, config_attribs, &config, 1, &configs) && configs > 0;
  const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                    4,
                                    EGL_CONTEXT_MINOR_VERSION,
                                    5,
                                    EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                    EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                    EGL_NONE};
  // EGL_KHR_no_config_context lets the context exist without a config where none offers a
  // pbuffer (Mesa's device platform).
  EGLContext ctx = eglCreateContext(dpy, any_config ? config : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT,
                                    context_attribs);
  if (ctx == EGL_NO_CONTEXT) {
    tried += "\n  " + what + ": no OpenGL 4.5 core context (" + egl_error() + ")";
    eglTerminate(dpy);
    return o;
  }
  if (!eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
    tried += "\n  " + what + ": the context cannot be made current without a surface (" +
             egl_error() + ")";
    eglDestroyContext(dpy, ctx);
    eglTerminate(dpy);
    return o;
  }
  o.display = dpy;
  o.context = ctx;
  return o;
}

} // namespace

EglContext::EglContext(int cuda_device) {
  std::string tried;
  Opened o;
  // glvnd's libEGL with NVIDIA's driver lists EGL_EXT_device_base (enumeration and query
  // together) rather than EGL_EXT_device_enumeration.
  auto client = [](const char* ext) { return epoxy_has_egl_extension(EGL_NO_DISPLAY, ext); };
  if ((client("EGL_EXT_device_enumeration") || client("EGL_EXT_device_base")) &&
      client("EGL_EXT_platform_device")) {
    EGLint n = 0;
    eglQueryDevicesEXT(0, nullptr, &n);
    std::vector<EGLDeviceEXT> devices(static_cast<std::size_t>(n > 0 ? n : 0));
    if (n > 0)
      eglQueryDevicesEXT(n, devices.data(), &n);
    for (EGLint k = 0; k < n && o.display == EGL_NO_DISPLAY; ++k) {
      const char* ext = eglQueryDeviceStringEXT(devices[std::size_t(k)], EGL_EXTENSIONS);
      const std::string exts = ext ? ext : "";
      if (cuda_device >= 0) {
        EGLAttrib id = -1;
        if (exts.find("EGL_NV_device_cuda") == std::string::npos ||
            !eglQueryDeviceAttribEXT(devices[std::size_t(k)], EGL_CUDA_DEVICE_NV, &id) ||
            id != cuda_device)
          continue;
      }
      EGLDisplay dpy =
          eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[std::size_t(k)], nullptr);
      o = open_on(dpy, "EGL device " + std::to_string(k), tried);
      if (o.display != EGL_NO_DISPLAY)
        info_.platform = "device";
    }
    if (n == 0)
      tried += "\n  EGL_EXT_device_enumeration lists no device";
  } else {
    const char* exts = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    tried += "\n  no EGL_EXT_device_enumeration (or _base) with EGL_EXT_platform_device among the "
             "client extensions: " +
             std::string(exts ? exts : "(none)");
  }
  if (o.display == EGL_NO_DISPLAY && cuda_device >= 0)
    throw Error("render: no EGL device drives CUDA device " + std::to_string(cuda_device) +
                " with OpenGL 4.5 core:" + tried);
  if (o.display == EGL_NO_DISPLAY) {
    if (epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_MESA_platform_surfaceless")) {
      o = open_on(
          eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr),
          "Mesa surfaceless platform", tried);
      if (o.display != EGL_NO_DISPLAY)
        info_.platform = "surfaceless";
    } else {
      tried += "\n  no EGL_MESA_platform_surfaceless";
    }
  }
  if (o.display == EGL_NO_DISPLAY)
    throw Error("render: no headless OpenGL 4.5 core context (install Mesa's libegl-mesa0 and "
                "libgl1-mesa-dri on a machine without a GPU):" +
                tried);
  display_ = o.display;
  context_ = o.context;
  auto str = [](GLenum e) {
    const auto* s = reinterpret_cast<const char*>(glGetString(e));
    return std::string(s ? s : "");
  };
  info_.vendor = str(GL_VENDOR);
  info_.renderer = str(GL_RENDERER);
  info_.version = str(GL_VERSION);
  glGetIntegerv(GL_MAJOR_VERSION, &info_.major);
  glGetIntegerv(GL_MINOR_VERSION, &info_.minor);
  info_.software = info_.renderer.find("llvmpipe") != std::string::npos ||
                   info_.renderer.find("softpipe") != std::string::npos;
  if (info_.major * 10 + info_.minor < 45) {
    const std::string got = info_.version;
    release();
    throw Error("render: the context is OpenGL " + got + ", 4.5 core is needed");
  }
}

EglContext::~EglContext() {
  release();
}

void EglContext::release() noexcept {
  if (display_) {
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (context_)
      eglDestroyContext(display_, context_);
    eglTerminate(display_);
  }
  display_ = context_ = nullptr;
}

void EglContext::make_current() const {
  if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
    throw Error("render: eglMakeCurrent failed (" + egl_error() + ")");
}

} // namespace kf::render
