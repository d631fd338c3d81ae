#include "kernels/exec/Streams.hpp"

namespace kf::exec {

#if defined(KF_WITH_CUDA)
// Defined in BackendCuda.cu.
CUstream_st* cuda_side_stream_create();
void cuda_stream_destroy(CUstream_st* s) noexcept;
void* cuda_order_event_create(const char* what);
void cuda_event_destroy(void* e) noexcept;
void cuda_stream_after(CUstream_st* waiter, CUstream_st* done, void* event, const char* label);
#endif

namespace {
thread_local CUstream_st* t_launch_stream = nullptr;
} // namespace

CUstream_st* launch_stream() noexcept {
  return t_launch_stream;
}

SideStream::SideStream([[maybe_unused]] Backend b) {
#if defined(KF_WITH_CUDA)
  if (b != Backend::Cuda)
    return;
  stream_ = cuda_side_stream_create();
  forked_ = cuda_order_event_create("the side stream's fork");
  joined_ = cuda_order_event_create("the side stream's join");
#endif
}

SideStream::~SideStream() {
#if defined(KF_WITH_CUDA)
  // Work still queued finishes first: the runtime releases a stream after its work.
  cuda_event_destroy(forked_);
  cuda_event_destroy(joined_);
  cuda_stream_destroy(stream_);
#endif
}

void SideStream::fork() {
#if defined(KF_WITH_CUDA)
  if (stream_)
    cuda_stream_after(stream_, nullptr, forked_, "side stream: fork");
#endif
}

void SideStream::join() {
#if defined(KF_WITH_CUDA)
  if (stream_)
    cuda_stream_after(nullptr, stream_, joined_, "side stream: join");
#endif
}

OnSideStream::OnSideStream(const SideStream& side) : previous_(t_launch_stream) {
  if (side.active())
    t_launch_stream = side.stream();
}

OnSideStream::~OnSideStream() {
  t_launch_stream = previous_;
}

} // namespace kf::exec
