#pragma once
// A second stream, for a pass that may run beside the legacy default stream's work: a rank's
// interior, computed while its border is computed, packed and sent (the border's pass is too short
// to fill the GPU, and the exchange waits for it). Everything else stays on the legacy default
// stream. While an OnSideStream scope lives, this thread's kernel launches (Algorithms.hpp) and
// timing events (Stopwatch, KernelTimeScope) go to the side stream; copies, reads and the scratch
// slots' users (sorts, scans, reductions) do not, and the last refuse to run there. On the CPU
// the work is done when the calls return: the side stream is inert.
#include "kernels/exec/Backend.hpp"

struct CUstream_st; // cudaStream_t without the CUDA headers

namespace kf::exec {

/// The stream this thread's launches and timing events go to (null: the legacy default stream).
CUstream_st* launch_stream() noexcept;

/// A non-blocking stream with the default priority (below the transports' streams), and the two
/// events that order it against the legacy default stream.
class SideStream {
public:
  explicit SideStream(Backend b);
  ~SideStream();
  SideStream(const SideStream&) = delete;
  SideStream& operator=(const SideStream&) = delete;

  /// False on the CPU: fork and join do nothing, and a scope leaves launches where they were.
  bool active() const { return stream_ != nullptr; }
  /// The side stream's later work waits for the legacy default stream's work queued so far.
  void fork();
  /// The legacy default stream's later work waits for the side stream's work queued so far.
  void join();
  CUstream_st* stream() const { return stream_; }

private:
  CUstream_st* stream_ = nullptr;
  void* forked_ = nullptr;
  void* joined_ = nullptr;
};

/// This thread's launches and timing events go to `side` until the scope ends (nowhere new when
/// `side` is inactive). Scopes nest: the previous stream comes back at the end.
class OnSideStream {
public:
  explicit OnSideStream(const SideStream& side);
  ~OnSideStream();
  OnSideStream(const OnSideStream&) = delete;
  OnSideStream& operator=(const OnSideStream&) = delete;

private:
  CUstream_st* previous_;
};

} // namespace kf::exec
