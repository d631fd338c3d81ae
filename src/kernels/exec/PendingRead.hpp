#pragma once
// A few values read back from the device without draining its queue: start() queues the copy
// behind the work queued so far, the host queues more work, then wait() collects the values. The
// GPU stays busy while the host waits for a decision (the step size, whether lists are stale).
#include "kernels/exec/Backend.hpp"

#include <cstddef>
#include <span>

namespace kf::exec {

template <typename T>
class PendingRead {
public:
  PendingRead(Backend b, std::size_t n, const char* what)
      : slot_(open_read_slot(b, n * sizeof(T), what)), n_(n), what_(what) {}
  PendingRead(const PendingRead&) = delete;
  PendingRead& operator=(const PendingRead&) = delete;
  ~PendingRead() { close_read_slot(slot_); }

  /// Queues the copy of src[0, n) (memory of the slot's backend).
  void start(const T* src, std::size_t n) {
    start_read(slot_, src, n * sizeof(T), what_);
    count_ = n;
    pending_ = true;
  }
  void start(const T* src) { start(src, n_); }
  bool pending() const { return pending_; }
  /// Waits for the values start() queued (valid until the next start()).
  std::span<const T> wait() {
    const void* p = finish_read(slot_, what_);
    pending_ = false;
    return {static_cast<const T*>(p), count_};
  }

private:
  ReadSlot* slot_;
  std::size_t n_, count_ = 0;
  const char* what_;
  bool pending_ = false;
};

} // namespace kf::exec
