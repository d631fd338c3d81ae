// What one exchange of device buffers costs between GPUs of one host, transport by transport,
// without the halo's packing: under mpiexec -n 2 (one GPU a rank), each rank sends one message of
// B bytes to the other and receives one, R exchanges back to back (start, finish), as a run's
// refreshes queue them. Two figures a size:
//   device  the GPU's time an exchange, measured between two events on the legacy default stream
//           while the host has already queued every exchange behind a long memset (so the host's
//           pace does not show): the exchange's latency on the device;
//   host    the host's time to queue one exchange (start + finish, no wait): what a step pays on
//           the host for it, which shows on the device where the GPU runs out of queued work.
// CSV on rank 0: transport, bytes, device_us, host_us.
//   mpiexec -n 2 build/cuda/bench/bench_transport --bytes 256,65536,1048576 --repeats 200
// CPU builds have no device transport: the program says so and exits 0.
#include "comm/MpiContext.hpp"
#include "comm/Transport.hpp"
#include "core/Error.hpp"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#if defined(KF_WITH_CUDA)
#include <cuda_runtime.h>
#endif

using namespace kf;

namespace {

#if defined(KF_WITH_CUDA)
void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw Error(std::string("bench_transport: ") + what + ": " + cudaGetErrorString(e));
}
#endif

} // namespace

int run(int argc, char** argv) {
  comm::MpiContext mpi;
  CLI::App app{"the device transports' exchange latency (mpiexec -n 2, a GPU a rank)"};
  std::vector<std::size_t> sizes{256, 4096, 65536, 1 << 20, 4 << 20};
  std::vector<std::string> kinds{"nccl"};
  int repeats = 200;
  app.add_option("--bytes", sizes, "message sizes")->delimiter(',');
  app.add_option("--transports", kinds, "transports to time")->delimiter(',');
  app.add_option("--repeats", repeats, "exchanges a size");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return mpi.root() ? app.exit(e) : 1;
  }
#if !defined(KF_WITH_CUDA)
  if (mpi.rank() == 0)
    std::printf("bench_transport: this build has no CUDA, so no device transport\n");
  return 0;
#else
  try {
    int count = 0;
    check(cudaGetDeviceCount(&count), "cudaGetDeviceCount");
    check(cudaSetDevice(mpi.rank() % std::max(count, 1)), "cudaSetDevice");
    const int peer = (mpi.rank() + 1) % mpi.size();
    std::size_t largest = 0;
    for (std::size_t b : sizes)
      largest = std::max(largest, b);
    void *send = nullptr, *recv = nullptr, *busy = nullptr;
    const std::size_t busy_bytes = std::size_t(16) << 30; // ~6 ms of memset on an H200
    check(cudaMalloc(&send, largest), "cudaMalloc");
    check(cudaMalloc(&recv, largest), "cudaMalloc");
    check(cudaMalloc(&busy, busy_bytes), "cudaMalloc");
    cudaEvent_t e0, e1;
    check(cudaEventCreate(&e0), "cudaEventCreate");
    check(cudaEventCreate(&e1), "cudaEventCreate");
    if (mpi.rank() == 0)
      std::printf("transport,bytes,device_us,host_us\n");
    for (const std::string& name : kinds) {
      const auto t =
          comm::make_transport(mpi, comm::parse_transport_kind(name), comm::MemorySpace::Device);
      for (std::size_t bytes : sizes) {
        const comm::SendBuffer s{peer, send, bytes};
        const comm::RecvBuffer r{peer, recv, bytes};
        auto exchange = [&] {
          t->start({&s, 1}, {&r, 1});
          t->finish();
        };
        for (int k = 0; k < 20; ++k) // warm: NCCL's connections, the inboxes' growth
          exchange();
        check(cudaDeviceSynchronize(), "cudaDeviceSynchronize");
        mpi.barrier();
        // Device: every exchange queued behind the memset, the events around them only.
        check(cudaMemsetAsync(busy, 1, busy_bytes, cudaStreamLegacy), "cudaMemsetAsync");
        check(cudaEventRecord(e0, cudaStreamLegacy), "cudaEventRecord");
        const auto h0 = std::chrono::steady_clock::now();
        for (int k = 0; k < repeats; ++k)
          exchange();
        const double host =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - h0).count();
        check(cudaEventRecord(e1, cudaStreamLegacy), "cudaEventRecord");
        check(cudaEventSynchronize(e1), "cudaEventSynchronize");
        float ms = 0;
        check(cudaEventElapsedTime(&ms, e0, e1), "cudaEventElapsedTime");
        const double device = mpi.max(double(ms) * 1e-3);
        const double host_max = mpi.max(host);
        if (mpi.rank() == 0)
          std::printf("%s,%zu,%.2f,%.2f\n", name.c_str(), bytes, device / repeats * 1e6,
                      host_max / repeats * 1e6);
        std::fflush(stdout);
      }
    }
    cudaFree(send);
    cudaFree(recv);
    cudaFree(busy);
  } catch (const Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  return 0;
#endif
}

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  const int rc = run(argc, argv);
  MPI_Finalize();
  return rc;
}
