#pragma once
// Whole-communicator exchanges of opaque bytes, for data shared out once a frame (a rendered
// snapshot's rows to the ranks drawing their region): every rank to every rank, or every rank's
// to all. Knows nothing of what the bytes hold.
#include <mpi.h>

#include <vector>

namespace kf::comm {

/// Collective over `comm`: rank r sends `to[k]` to rank k (to.size() == ranks) and gets back
/// what every rank sent it, concatenated in rank order. A part over 2^31 - 1 bytes is a
/// kf::Error (MPI's counts are ints).
std::vector<unsigned char> exchange_bytes(MPI_Comm comm,
                                          const std::vector<std::vector<unsigned char>>& to);

/// Collective over `comm`: every rank's `mine`, concatenated in rank order, on every rank.
std::vector<unsigned char> gather_bytes_to_all(MPI_Comm comm,
                                               const std::vector<unsigned char>& mine);

} // namespace kf::comm
