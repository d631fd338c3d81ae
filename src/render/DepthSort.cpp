#include "render/DepthSort.hpp"

#include "core/Error.hpp"
#include "kernels/exec/Algorithms.hpp"

#include <epoxy/gl.h>

#if defined(KF_WITH_CUDA)
#include "kernels/exec/CudaCheck.hpp"
#include <cuda_gl_interop.h>
#endif

#include <string>

namespace kf::render {

DepthSort::DepthSort(bool on_cuda) : on_cuda_(on_cuda) {
#if !defined(KF_WITH_CUDA)
  if (on_cuda)
    throw Error("render: a CUDA sort of the draw order needs the CUDA build");
#endif
}

DepthSort::~DepthSort() {
  unregister();
}

void DepthSort::unregister() noexcept {
#if defined(KF_WITH_CUDA)
  for (auto*& r : resource_)
    if (r) {
      cudaGraphicsUnregisterResource(static_cast<cudaGraphicsResource_t>(r));
      r = nullptr;
    }
#endif
  registered_[0] = registered_[1] = 0;
}

void DepthSort::sort(unsigned keys, unsigned values, std::size_t n) {
  if (n < 2)
    return;
  const int key_bits = 32;
  if (on_cuda_) {
#if defined(KF_WITH_CUDA)
    const std::string what = "render: sorting " + std::to_string(n) + " draw keys in CUDA";
    if (registered_[0] != keys || registered_[1] != values) {
      unregister();
      const unsigned buffer[2] = {keys, values};
      for (int i = 0; i < 2; ++i) {
        cudaGraphicsResource_t r = nullptr;
        KF_CUDA(cudaGraphicsGLRegisterBuffer(&r, buffer[i], cudaGraphicsRegisterFlagsNone),
                what + " (registering GL buffer " + std::to_string(buffer[i]) + ")");
        resource_[i] = r;
        registered_[i] = buffer[i];
      }
    }
    cudaGraphicsResource_t r[2] = {static_cast<cudaGraphicsResource_t>(resource_[0]),
                                   static_cast<cudaGraphicsResource_t>(resource_[1])};
    // Mapping orders the GL work that wrote the keys before CUDA's; unmapping, CUDA's before
    // GL's next use.
    KF_CUDA(cudaGraphicsMapResources(2, r, 0), what + " (mapping)");
    void* p[2] = {nullptr, nullptr};
    std::size_t bytes[2] = {0, 0};
    for (int i = 0; i < 2; ++i)
      KF_CUDA(cudaGraphicsResourceGetMappedPointer(&p[i], &bytes[i], r[i]), what);
    if (bytes[0] < n * sizeof(std::uint32_t) || bytes[1] < n * sizeof(std::uint32_t)) {
      cudaGraphicsUnmapResources(2, r, 0);
      throw Error(what + ": the GL buffers hold " + std::to_string(bytes[0]) + " and " +
                  std::to_string(bytes[1]) + " bytes");
    }
    exec::sort_by_key({exec::Backend::Cuda}, static_cast<std::uint32_t*>(p[0]),
                      static_cast<std::uint32_t*>(p[1]), n, key_bits, "render: draw order");
    KF_CUDA(cudaGraphicsUnmapResources(2, r, 0), what + " (unmapping)");
    return;
#endif
  }
  host_keys_.resize(n);
  host_values_.resize(n);
  const auto bytes = GLsizeiptr(n * sizeof(std::uint32_t));
  glGetNamedBufferSubData(keys, 0, bytes, host_keys_.data());
  glGetNamedBufferSubData(values, 0, bytes, host_values_.data());
  exec::sort_by_key({exec::Backend::Cpu}, host_keys_.data(), host_values_.data(), n, key_bits,
                    "render: draw order");
  glNamedBufferSubData(keys, 0, bytes, host_keys_.data());
  glNamedBufferSubData(values, 0, bytes, host_values_.data());
}

} // namespace kf::render
