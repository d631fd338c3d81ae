#pragma once
#include "core/Error.hpp"
#include "kernels/exec/Backend.hpp"

#include <algorithm>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

namespace kf::exec {

/// An owning array on one backend. Resizing keeps the leading elements. Copies to and from the
/// host are explicit (to_host / assign) so that hidden transfers cannot creep into hot loops.
template <typename T>
class DeviceBuffer {
public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(Backend b, std::size_t n = 0, const char* what = "buffer")
      : backend_(b), what_(what) {
    resize(n);
  }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& o) noexcept { swap(o); }
  DeviceBuffer& operator=(DeviceBuffer&& o) noexcept {
    swap(o);
    return *this;
  }
  ~DeviceBuffer() { free_bytes(backend_, ptr_); }

  void swap(DeviceBuffer& o) noexcept {
    std::swap(backend_, o.backend_);
    std::swap(ptr_, o.ptr_);
    std::swap(size_, o.size_);
    std::swap(capacity_, o.capacity_);
    std::swap(what_, o.what_);
  }

  Backend backend() const { return backend_; }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  T* data() { return ptr_; }
  const T* data() const { return ptr_; }
  std::size_t bytes() const { return size_ * sizeof(T); }
  std::size_t capacity_bytes() const { return capacity_ * sizeof(T); }

  std::size_t capacity() const { return capacity_; }

  /// Room for n elements exactly, where there is less (the first size() kept): for a column
  /// whose length its owner knows ahead, where resize()'s geometric growth would leave half of
  /// it unused.
  void reserve(std::size_t n) {
    if (n > capacity_)
      reallocate(n);
  }

  /// Room for size() elements exactly, where there is more: for a column cut to a share of what
  /// it held (a rank keeping its points of a whole set), whose spare room would stay held.
  void shrink_to_fit() {
    if (capacity_ > size_)
      reallocate(size_);
  }

  /// Frees the storage, contents and all.
  void release() {
    free_bytes(backend_, ptr_);
    ptr_ = nullptr;
    size_ = capacity_ = 0;
  }
  /// reserve() for contents that will all be written again: storage that must grow is freed
  /// first, so that old and new are never held at once (reserve copies; a growth's peak held
  /// both). The contents are lost where it grows.
  void reserve_discarding(std::size_t n) {
    if (n > capacity_) {
      release();
      reserve(n);
    }
  }
  /// resize_snug() whose contents need not be kept (reserve_discarding).
  void resize_snug_discarding(std::size_t n) {
    if (n > capacity_)
      reserve_discarding(capacity_ == 0 ? n : n + n / 16);
    size_ = n;
  }

  /// resize(), growing to n and a sixteenth more where it grows: for a column of particles, whose
  /// count moves a little between sorts (migration, ghosts, drops), and which is most of what a
  /// rank holds: geometric growth would leave up to a third of it unused.
  void resize_snug(std::size_t n) {
    if (n > capacity_)
      reserve(capacity_ == 0 ? n : n + n / 16); // the first exactly, as resize()
    size_ = n;
  }

  /// Grows geometrically; the first min(old, new) elements are kept.
  void resize(std::size_t n) {
    if (n > capacity_)
      reserve(capacity_ == 0 ? n : std::max(n, capacity_ + capacity_ / 2));
    size_ = n;
  }

  /// Replaces the contents with host data.
  void assign(const T* src, std::size_t n) {
    resize(n);
    if (n)
      copy_bytes(ptr_, backend_, src, Backend::Cpu, n * sizeof(T));
  }
  void assign(const std::vector<T>& v) { assign(v.data(), v.size()); }

  /// Copies the contents to a host vector.
  std::vector<T> to_host() const {
    std::vector<T> v(size_);
    if (size_)
      copy_bytes(v.data(), Backend::Cpu, ptr_, backend_, size_ * sizeof(T));
    return v;
  }

  /// Copies element i to the host: a small read of one result among several, the others (unwritten
  /// in a run without their phase) left unread.
  T host_value(std::size_t i) const {
    if (i >= size_)
      throw Error(std::string(what_) + ": element " + std::to_string(i) + " of " +
                  std::to_string(size_));
    T v;
    copy_bytes(&v, Backend::Cpu, ptr_ + i, backend_, sizeof(T));
    return v;
  }

  /// Copies `n` elements from another buffer (any backend) starting at the given offsets.
  void copy_from(const DeviceBuffer& src, std::size_t n, std::size_t dst_off = 0,
                 std::size_t src_off = 0) {
    if (n)
      copy_bytes(ptr_ + dst_off, backend_, src.ptr_ + src_off, src.backend_, n * sizeof(T));
  }

  /// Fills every byte with `byte` (tests poison outputs with 0xFF so unwritten elements show).
  void poison(unsigned char byte = 0xFF) { fill_bytes(backend_, ptr_, byte, bytes()); }

private:
  /// Room for n >= size() elements, the first size() kept (alloc_bytes holds nothing for 0).
  void reallocate(std::size_t n) {
    T* p = static_cast<T*>(alloc_bytes(backend_, n * sizeof(T), what_));
    if (size_ > 0)
      copy_bytes(p, backend_, ptr_, backend_, size_ * sizeof(T));
    free_bytes(backend_, ptr_);
    ptr_ = p;
    capacity_ = n;
  }

  Backend backend_ = Backend::Cpu;
  T* ptr_ = nullptr;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;
  const char* what_ = "buffer";
};

} // namespace kf::exec
