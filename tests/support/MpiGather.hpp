#pragma once
// What every rank holds, concatenated in rank order on every rank (MPI tests).
#include <mpi.h>

#include <numeric>
#include <vector>

namespace kf::test {

template <typename V>
std::vector<V> allgather(const std::vector<V>& mine, MPI_Comm comm = MPI_COMM_WORLD) {
  int size = 0;
  MPI_Comm_size(comm, &size);
  int n = static_cast<int>(mine.size() * sizeof(V));
  std::vector<int> counts(size), displs(size);
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
  std::exclusive_scan(counts.begin(), counts.end(), displs.begin(), 0);
  std::vector<V> all(std::accumulate(counts.begin(), counts.end(), std::size_t(0)) / sizeof(V));
  MPI_Allgatherv(mine.data(), n, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE,
                 comm);
  return all;
}

} // namespace kf::test
