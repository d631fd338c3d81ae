#include "comm/MpiContext.hpp"

namespace kf::comm {

MpiContext::MpiContext(MPI_Comm comm) : comm_(comm) {
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
  MPI_Comm local;
  MPI_Comm_split_type(comm_, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &local);
  MPI_Comm_rank(local, &local_rank_);
  MPI_Comm_size(local, &local_size_);
  MPI_Comm_free(&local);
}

MpiContext::~MpiContext() = default;

double MpiContext::max(double v) const {
  double r;
  MPI_Allreduce(&v, &r, 1, MPI_DOUBLE, MPI_MAX, comm_);
  return r;
}
double MpiContext::min(double v) const {
  double r;
  MPI_Allreduce(&v, &r, 1, MPI_DOUBLE, MPI_MIN, comm_);
  return r;
}
double MpiContext::sum(double v) const {
  double r;
  MPI_Allreduce(&v, &r, 1, MPI_DOUBLE, MPI_SUM, comm_);
  return r;
}
std::uint64_t MpiContext::sum(std::uint64_t v) const {
  std::uint64_t r;
  MPI_Allreduce(&v, &r, 1, MPI_UINT64_T, MPI_SUM, comm_);
  return r;
}
void MpiContext::sum_in_place(std::span<std::uint64_t> v) const {
  MPI_Allreduce(MPI_IN_PLACE, v.data(), static_cast<int>(v.size()), MPI_UINT64_T, MPI_SUM, comm_);
}
void MpiContext::sum_in_place(std::span<double> v) const {
  MPI_Allreduce(MPI_IN_PLACE, v.data(), static_cast<int>(v.size()), MPI_DOUBLE, MPI_SUM, comm_);
}
void MpiContext::min_in_place(std::span<double> v) const {
  MPI_Allreduce(MPI_IN_PLACE, v.data(), static_cast<int>(v.size()), MPI_DOUBLE, MPI_MIN, comm_);
}
void MpiContext::max_in_place(std::span<double> v) const {
  MPI_Allreduce(MPI_IN_PLACE, v.data(), static_cast<int>(v.size()), MPI_DOUBLE, MPI_MAX, comm_);
}
std::uint64_t MpiContext::exscan(std::uint64_t v) const {
  std::uint64_t r = 0;
  MPI_Exscan(&v, &r, 1, MPI_UINT64_T, MPI_SUM, comm_);
  return rank_ == 0 ? 0 : r;
}
void MpiContext::barrier() const {
  MPI_Barrier(comm_);
}

} // namespace kf::comm
