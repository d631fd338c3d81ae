#pragma once
// The NCCL transport (CUDA build only): grouped ncclSend/ncclRecv of device buffers on a CUDA
// stream of its own, so that the kernels queued after start() (the interior of a rank's region)
// run while the messages move. NCCL needs a GPU a rank; make_transport picks it only then.
#include "comm/Transport.hpp"

#include <cuda_runtime.h>
#include <nccl.h>

namespace kf::comm {

class NcclTransport final : public Transport {
public:
  /// Collective over ctx's communicator: makes `device` this process's current device and builds
  /// the NCCL communicator from a unique id that rank 0 broadcasts over MPI. Work is queued on
  /// `stream`, which must belong to `device` (null: a non-blocking stream of its own). Each
  /// start() waits for the work queued before it on the legacy default stream (where the kernels
  /// filling the send buffers run) through an event, not the host.
  NcclTransport(const MpiContext& ctx, int device, cudaStream_t stream);
  ~NcclTransport() override;

  std::string_view name() const override { return "nccl"; }
  MemorySpace memory_space() const override { return MemorySpace::Device; }
  int device() const { return device_; }
  cudaStream_t stream() const { return stream_; }

private:
  void do_start(std::span<const SendBuffer> sends, std::span<const RecvBuffer> receives) override;
  /// Orders the legacy default stream after the exchange (an event, not a host wait): the work
  /// queued there after finish() sees the received data; the host does not wait for it (it
  /// reads device data only through copies on that stream, which are ordered after it).
  /// NCCL's asynchronous errors are checked without waiting, so one surfaces at a later finish.
  void do_finish() override;
  /// ncclAllReduce (ncclMax) in place on the transport's stream, ordered between the legacy
  /// default stream's work before and after it by events, as an exchange is.
  void do_max_in_place(void* data, std::size_t n, bool is_double) override;

  int device_;
  cudaStream_t stream_;
  bool own_stream_ = false;
  cudaEvent_t filled_ = nullptr; // the default stream's work before start()
  cudaEvent_t moved_ = nullptr;  // the exchange's end on NCCL's stream
  ncclComm_t nccl_ = nullptr;
};

} // namespace kf::comm
