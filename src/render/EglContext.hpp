#pragma once
// A headless OpenGL 4.5 core context through EGL: no window and no display server, on the
// NVIDIA driver (the EGL device of the rank's CUDA device) and on Mesa's llvmpipe on machines
// without a GPU. The same rendering code runs on both (DESIGN §8). GL entry points come from
// libepoxy; nothing here knows about particles.
#include <string>

namespace kf::render {

/// What the driver says it is (for logs and for tests that must know llvmpipe from a GPU).
struct ContextInfo {
  std::string vendor, renderer, version;
  std::string platform; // "device" (EGL_EXT_platform_device) or "surfaceless"
  int major = 0, minor = 0;
  bool software = false; // llvmpipe or another CPU rasterizer
};

class EglContext {
public:
  /// cuda_device >= 0: the EGL device whose EGL_CUDA_DEVICE_NV is that CUDA device (chosen by
  /// its CUDA id, never by its place in EGL's list, which need not agree). -1: the first EGL
  /// device that gives a 4.5 core context, else Mesa's surfaceless platform. The context is
  /// current on the calling thread when the constructor returns. A kf::Error says what was
  /// missing (no EGL, no device, no 4.5 core context).
  explicit EglContext(int cuda_device = -1);
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;

  /// Makes the context current on the calling thread (it is after construction).
  void make_current() const;
  const ContextInfo& info() const { return info_; }

private:
  void release() noexcept;
  void* display_ = nullptr; // EGLDisplay
  void* context_ = nullptr; // EGLContext
  ContextInfo info_;
};

} // namespace kf::render
