#pragma once
// The process's place in the MPI job: rank, size, the rank-local index used to pick a GPU, and
// the global reductions (dt, diagnostics). Knows nothing of physics.
#include <mpi.h>

#include <cstdint>
#include <span>

namespace kf::comm {

class MpiContext {
public:
  explicit MpiContext(MPI_Comm comm = MPI_COMM_WORLD);
  MpiContext(const MpiContext&) = delete;
  MpiContext& operator=(const MpiContext&) = delete;
  ~MpiContext();

  MPI_Comm comm() const { return comm_; }
  int rank() const { return rank_; }
  int size() const { return size_; }
  /// Rank among the processes on this node (rank -> GPU is local_rank % device count).
  int local_rank() const { return local_rank_; }
  /// Number of processes on this node (ranks that could share its GPUs).
  int local_size() const { return local_size_; }
  bool root() const { return rank_ == 0; }

  double max(double v) const;
  double min(double v) const;
  double sum(double v) const;
  std::uint64_t sum(std::uint64_t v) const;
  /// Each element replaced by its sum (min, max) over the ranks.
  void sum_in_place(std::span<std::uint64_t> v) const;
  void sum_in_place(std::span<double> v) const;
  void min_in_place(std::span<double> v) const;
  void max_in_place(std::span<double> v) const;
  /// Exclusive prefix sum of v over ranks (0 on rank 0): offsets of this rank's rows.
  std::uint64_t exscan(std::uint64_t v) const;
  void barrier() const;

private:
  MPI_Comm comm_;
  int rank_ = 0, size_ = 1, local_rank_ = 0, local_size_ = 1;
};

} // namespace kf::comm
