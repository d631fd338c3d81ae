#pragma once
// An array kept on the host that kernels of a backend read in place (alloc_host_readable):
// page-locked on a device, whose kernels read it across the bus with the host's pointer. For a
// table a rank keeps whole but reads only a few rows of, now and then (the knit mesh's rows on
// N ranks: KnitSystem), where a device copy would hold the whole table on every GPU. Resizable
// in place (a rank's rows migrate with its points).
#include "kernels/exec/Backend.hpp"

#include <algorithm>
#include <cstring>
#include <utility>
#include <vector>

namespace kf::exec {

template <typename U>
class HostReadable {
public:
  HostReadable() = default;
  HostReadable(Backend b, const std::vector<U>& v, const char* what) : backend_(b), what_(what) {
    p_ = static_cast<U*>(alloc_host_readable(b, v.size() * sizeof(U), what));
    if (!v.empty())
      std::memcpy(static_cast<void*>(p_), v.data(), v.size() * sizeof(U));
    n_ = cap_ = v.size();
  }
  /// n elements, zeroed, to fill through data().
  HostReadable(Backend b, std::size_t n, const char* what) : backend_(b), what_(what) {
    p_ = static_cast<U*>(alloc_host_readable(b, n * sizeof(U), what));
    if (n)
      std::memset(static_cast<void*>(p_), 0, n * sizeof(U));
    n_ = cap_ = n;
  }
  HostReadable(const HostReadable&) = delete;
  HostReadable& operator=(const HostReadable&) = delete;
  HostReadable(HostReadable&& o) noexcept { swap(o); }
  HostReadable& operator=(HostReadable&& o) noexcept {
    swap(o);
    return *this;
  }
  ~HostReadable() { free_host_readable(backend_, p_); }
  void swap(HostReadable& o) noexcept {
    std::swap(backend_, o.backend_);
    std::swap(p_, o.p_);
    std::swap(n_, o.n_);
    std::swap(cap_, o.cap_);
    std::swap(what_, o.what_);
  }
  /// n elements, the first min(n, size()) kept, any new ones zeroed. Grows the allocation by
  /// half again when it must (page-locked allocations are slow: not at every migration).
  void resize(std::size_t n) {
    if (n > cap_) {
      const std::size_t cap = std::max(n, cap_ + cap_ / 2);
      U* p = static_cast<U*>(alloc_host_readable(backend_, cap * sizeof(U), what_));
      if (n_)
        std::memcpy(static_cast<void*>(p), p_, n_ * sizeof(U));
      free_host_readable(backend_, p_);
      p_ = p;
      cap_ = cap;
    }
    if (n > n_)
      std::memset(static_cast<void*>(p_ + n_), 0, (n - n_) * sizeof(U));
    n_ = n;
  }

  U* data() { return p_; }
  const U* data() const { return p_; }
  std::size_t size() const { return n_; }
  std::size_t bytes() const { return n_ * sizeof(U); }
  std::size_t capacity_bytes() const { return cap_ * sizeof(U); }
  const U& operator[](std::size_t i) const { return p_[i]; }

private:
  Backend backend_ = Backend::Cpu;
  U* p_ = nullptr;
  std::size_t n_ = 0, cap_ = 0;
  const char* what_ = "host_readable";
};

} // namespace kf::exec
