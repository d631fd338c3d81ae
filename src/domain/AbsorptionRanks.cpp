#include "domain/AbsorptionRanks.hpp"

#include "domain/ExchangeColumns.hpp"

#include <algorithm>
#include <mpi.h>
#include <numeric>

namespace kf {

static_assert(KnitHalo<float>::kAbsent == kNoTarget, "an absent knit point is no target");

template <typename T>
AbsorptionRanks<T>::AbsorptionRanks(RankExchange<T>& ranks, KnitHalo<T>& halo, KnitSystem<T>& knit,
                                    ConservingAbsorption<T>& absorption)
    : ranks_(ranks), halo_(halo), knit_(knit), absorption_(absorption) {
  const auto cols = absorption.point_columns();
  halo.carry({cols.begin(), cols.end()},
             [&absorption](const std::vector<std::uint64_t>& ids, std::size_t owned) {
               absorption.localize(ids, owned);
             });
}

template <typename T>
AbsorptionSplit<T> AbsorptionRanks<T>::split(const exec::Exec& ex, FluidSet<T>& fluid) {
  halo_.ready();
  AbsorptionSplit<T> s;
  s.knit_owned = knit_.owned();
  s.fluid_owned = ranks_.owned_flags();
  s.knit_of_id = halo_.local_of_id().data();
  s.fluid_ghost_rows = [this](exec::DeviceBuffer<std::uint32_t>& b) {
    const comm::Column c[] = {column(b)};
    ranks_.refresh(c);
  };
  s.knit_ghost_rows = [this](exec::DeviceBuffer<T>& b) {
    const comm::Column c[] = {column(b)};
    halo_.refresh(c);
  };
  s.knit_ghost_state = [this] {
    auto& set = knit_.set();
    const comm::Column c[] = {column(*absorption_.point_columns()[1]), column(set.m),
                              column(set.v)};
    halo_.refresh(c);
  };
  s.number_drops = [this](std::vector<std::uint64_t>& ids) -> std::uint64_t {
    // Every rank's emitters' ids (a few a step), in id order: a drop's place among them.
    const MPI_Comm comm = ranks_.mpi().comm();
    const int size = ranks_.ranks();
    int mine = static_cast<int>(ids.size());
    std::vector<int> counts(size), displs(size);
    MPI_Allgather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
    std::exclusive_scan(counts.begin(), counts.end(), displs.begin(), 0);
    std::vector<std::uint64_t> all(std::size_t(displs.back()) + std::size_t(counts.back()));
    MPI_Allgatherv(ids.data(), mine, MPI_UINT64_T, all.data(), counts.data(), displs.data(),
                   MPI_UINT64_T, comm);
    std::sort(all.begin(), all.end());
    for (auto& id : ids)
      id = static_cast<std::uint64_t>(std::lower_bound(all.begin(), all.end(), id) - all.begin());
    return all.size();
  };
  s.drop_fluid_ghosts = [this, &ex, &fluid] { ranks_.drop_ghosts(ex, fluid); };
  return s;
}

template <typename T>
bool AbsorptionRanks<T>::settle(const exec::Exec& ex, FluidSet<T>& fluid,
                                const typename ConservingAbsorption<T>::Absorbed& got) {
  std::uint64_t both[2] = {got.removed, got.partial};
  MPI_Allreduce(MPI_IN_PLACE, both, 2, MPI_UINT64_T, MPI_SUM, ranks_.mpi().comm());
  if (both[0] > 0) {
    ranks_.remove(ex, fluid, absorption_.keep());
    return true;
  }
  if (both[1] > 0) {
    const comm::Column c[] = {column(fluid.m), column(fluid.a)};
    ranks_.refresh(c);
  }
  return false;
}

template class AbsorptionRanks<float>;
template class AbsorptionRanks<double>;

} // namespace kf
