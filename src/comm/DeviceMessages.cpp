#include "comm/DeviceMessages.hpp"

#include "core/Error.hpp"

#include <cstring>

namespace kf::comm {

const char* base_name(const char* file) {
  const char* slash = std::strrchr(file, '/');
  return slash ? slash + 1 : file;
}

void throw_cuda(const std::string& who, cudaError_t e, const char* call, const char* file,
                int line) {
  (void)cudaGetLastError(); // a sticky error stays; a plain one must not surface at a later call
  throw Error(who + ": " + call + " failed at " + base_name(file) + ":" + std::to_string(line) +
              ": " + cudaGetErrorName(e) + ": " + cudaGetErrorString(e));
}

void require_device_buffers(const std::string& who, std::span<const SendBuffer> sends,
                            std::span<const RecvBuffer> receives) {
  auto check = [&](const void* p, std::size_t bytes, const char* what, int peer) {
    if (bytes == 0)
      return;
    cudaPointerAttributes a{};
    const cudaError_t e = cudaPointerGetAttributes(&a, p);
    if (e != cudaSuccess)
      throw_cuda(who, e, "cudaPointerGetAttributes", __FILE__, __LINE__);
    if (a.type != cudaMemoryTypeDevice && a.type != cudaMemoryTypeManaged)
      throw Error(who + ": the " + what + " buffer for rank " + std::to_string(peer) +
                  " is host memory; this transport moves device buffers (stage through the "
                  "device, or use the mpi transport)");
  };
  for (const SendBuffer& s : sends)
    check(s.data, s.bytes, "send", s.peer);
  for (const RecvBuffer& r : receives)
    check(r.data, r.bytes, "receive", r.peer);
}

void copy_to_self(const std::string& who, int rank, std::span<const SendBuffer> sends,
                  std::span<const RecvBuffer> receives, cudaStream_t stream) {
  std::vector<const SendBuffer*> out;
  std::vector<const RecvBuffer*> in;
  for (const SendBuffer& s : sends)
    if (s.peer == rank)
      out.push_back(&s);
  for (const RecvBuffer& r : receives)
    if (r.peer == rank)
      in.push_back(&r);
  if (out.size() != in.size())
    throw Error(who + ": " + std::to_string(out.size()) + " sends to itself but " +
                std::to_string(in.size()) + " receives from itself");
  for (std::size_t k = 0; k < out.size(); ++k)
    if (out[k]->bytes != in[k]->bytes)
      throw Error(who + ": message " + std::to_string(k) + " to itself sends " +
                  std::to_string(out[k]->bytes) + " bytes into a receive of " +
                  std::to_string(in[k]->bytes));
  for (std::size_t k = 0; k < out.size(); ++k)
    if (out[k]->bytes > 0) {
      const cudaError_t e = cudaMemcpyAsync(in[k]->data, out[k]->data, out[k]->bytes,
                                            cudaMemcpyDeviceToDevice, stream);
      if (e != cudaSuccess)
        throw_cuda(who, e, "cudaMemcpyAsync (a message to itself)", __FILE__, __LINE__);
    }
}

} // namespace kf::comm
