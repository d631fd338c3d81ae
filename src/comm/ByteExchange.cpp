#include "comm/ByteExchange.hpp"

#include "comm/Transport.hpp"
#include "core/Error.hpp"

#include <climits>
#include <numeric>
#include <string>

namespace kf::comm {

namespace {

int count_of(std::size_t bytes) {
  if (bytes > std::size_t(INT_MAX))
    throw Error("comm: " + std::to_string(bytes) + " bytes in one message (MPI counts stop at " +
                std::to_string(INT_MAX) + ")");
  return int(bytes);
}

void check(int rc, const char* what) {
  if (rc != MPI_SUCCESS)
    throw Error(std::string("comm: ") + what + ": " + mpi_error_string(rc));
}

/// Displacements of `counts` laid end to end; a kf::Error past INT_MAX in all.
std::vector<int> displacements(const std::vector<int>& counts) {
  std::vector<int> d(counts.size(), 0);
  std::size_t at = 0;
  for (std::size_t k = 0; k < counts.size(); ++k) {
    d[k] = count_of(at);
    at += std::size_t(counts[k]);
  }
  count_of(at);
  return d;
}

} // namespace

std::vector<unsigned char> exchange_bytes(MPI_Comm comm,
                                          const std::vector<std::vector<unsigned char>>& to) {
  int ranks = 0;
  MPI_Comm_size(comm, &ranks);
  if (to.size() != std::size_t(ranks))
    throw Error("comm: exchange_bytes takes a part for each of the " + std::to_string(ranks) +
                " ranks, not " + std::to_string(to.size()));
  std::vector<int> send(static_cast<std::size_t>(ranks)), receive(send.size());
  std::vector<unsigned char> out_bytes;
  for (int k = 0; k < ranks; ++k) {
    send[std::size_t(k)] = count_of(to[std::size_t(k)].size());
    out_bytes.insert(out_bytes.end(), to[std::size_t(k)].begin(), to[std::size_t(k)].end());
  }
  check(MPI_Alltoall(send.data(), 1, MPI_INT, receive.data(), 1, MPI_INT, comm),
        "the exchange's counts");
  const std::vector<int> send_at = displacements(send), receive_at = displacements(receive);
  std::vector<unsigned char> in(std::size_t(std::accumulate(receive.begin(), receive.end(), 0LL)));
  check(MPI_Alltoallv(out_bytes.data(), send.data(), send_at.data(), MPI_BYTE, in.data(),
                      receive.data(), receive_at.data(), MPI_BYTE, comm),
        "the exchange");
  return in;
}

std::vector<unsigned char> gather_bytes_to_all(MPI_Comm comm,
                                               const std::vector<unsigned char>& mine) {
  int ranks = 0;
  MPI_Comm_size(comm, &ranks);
  const int count = count_of(mine.size());
  std::vector<int> counts(static_cast<std::size_t>(ranks));
  check(MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm), "the gather's counts");
  const std::vector<int> at = displacements(counts);
  std::vector<unsigned char> all(std::size_t(std::accumulate(counts.begin(), counts.end(), 0LL)));
  check(MPI_Allgatherv(mine.data(), count, MPI_BYTE, all.data(), counts.data(), at.data(), MPI_BYTE,
                       comm),
        "the gather");
  return all;
}

} // namespace kf::comm
