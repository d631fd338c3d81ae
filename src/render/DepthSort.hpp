#pragma once
// Sorting a pass's draw order where its keys were computed: pairs of 32-bit keys and values held
// in two GL buffers, sorted by key, stable. On an NVIDIA context with CUDA the buffers are mapped
// into CUDA (CUDA-GL interop) and sorted there by CUB's radix sort (kernels/exec's
// sort_by_key); elsewhere (Mesa llvmpipe) they are read back and sorted by the host's radix sort
// (the same call on the CPU backend), then written back. No sort is written here.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace kf::render {

class DepthSort {
public:
  /// on_cuda: the GL context is the current CUDA device's (the EGL device chosen by its CUDA
  /// id); needs the CUDA build. Otherwise the host sorts.
  explicit DepthSort(bool on_cuda);
  ~DepthSort();
  DepthSort(const DepthSort&) = delete;
  DepthSort& operator=(const DepthSort&) = delete;

  /// Sorts the first n pairs of the GL buffers `keys` and `values` (uint32 each) by key,
  /// ascending, pairs of equal keys in their order. GL work writing them must have been issued
  /// (the mapping waits for it); GL work after this call sees the sorted pairs.
  void sort(unsigned keys, unsigned values, std::size_t n);
  bool on_cuda() const { return on_cuda_; }

private:
  bool on_cuda_;
  // The buffers registered with CUDA (re-registered when the pass's buffers change).
  unsigned registered_[2] = {0, 0};
  void* resource_[2] = {nullptr, nullptr};
  std::vector<std::uint32_t> host_keys_, host_values_;
  void unregister() noexcept;
};

} // namespace kf::render
