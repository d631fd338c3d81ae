#include "kernels/exec/Stopwatch.hpp"

#include "core/Error.hpp"

namespace kf::exec {

#if defined(KF_WITH_CUDA)
// Defined in BackendCuda.cu.
void* cuda_timing_event_create(const char* what);
void cuda_event_destroy(void* e) noexcept;
void cuda_event_record(void* e, const char* label);
void cuda_event_wait(void* e, const char* label);
double cuda_event_seconds(void* start, void* end, const char* label);
#endif

Stopwatch::~Stopwatch() {
#if defined(KF_WITH_CUDA)
  for (void* e : events_)
    cuda_event_destroy(e);
#endif
}

void Stopwatch::start() {
  if (open_)
    throw Error("stopwatch: started twice without a stop");
  open_ = true;
  if (backend_ == Backend::Cpu) {
    t0_ = std::chrono::steady_clock::now();
    return;
  }
#if defined(KF_WITH_CUDA)
  while (events_.size() < used_ + 2)
    events_.push_back(cuda_timing_event_create("stopwatch"));
  cuda_event_record(events_[used_], "stopwatch start");
#endif
}

void Stopwatch::stop() {
  if (!open_)
    throw Error("stopwatch: stopped without a start");
  open_ = false;
  if (backend_ == Backend::Cpu) {
    host_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    return;
  }
#if defined(KF_WITH_CUDA)
  cuda_event_record(events_[used_ + 1], "stopwatch stop");
  used_ += 2;
#endif
}

double Stopwatch::collect() {
  double s = host_seconds_;
  host_seconds_ = 0;
#if defined(KF_WITH_CUDA)
  if (used_ > 0) {
    // Every interval's end: one on a side stream (Streams.hpp) may end after a later one.
    for (std::size_t k = 0; k < used_; k += 2) {
      cuda_event_wait(events_[k + 1], "stopwatch");
      s += cuda_event_seconds(events_[k], events_[k + 1], "stopwatch");
    }
    // An interval still open keeps its start: it moves to the front.
    if (open_)
      std::swap(events_[0], events_[used_]);
    used_ = 0;
  }
#endif
  return s;
}

} // namespace kf::exec
