#pragma once
// The conserving absorption on N ranks (P5; docs/ARCHITECTURE.md, "The conserving absorption on
// N ranks"). Each transfer is computed once, by the owner of the side that gains or loses, from
// copies of the other side that equal their owners' values:
// - absorb: a fluid particle's owner chooses its knit point (the ghosts take their owners'
//   choices, by id); a knit point's owner takes in from the owned and ghost particles that chose
//   it, and the particles' owners give the same amounts (absorbed_amount of the fraction the
//   point's owner computed);
// - diffuse: each owned point sums its links' fluxes (antisymmetric bit for bit), its ghosts
//   refreshed after every substep;
// - emit: the owned points emit, their drops numbered by point id as one rank numbers them.
// The masses travel with the knit points (KnitHalo::carry), the links are rebuilt over local
// indices at each choice of ghosts. The job's free + absorbed + outflowed mass is conserved to
// rounding, and a split run is the one-rank run (tests/mpi/test_distributed_knit_mpi).
#include "domain/KnitHalo.hpp"
#include "domain/KnitSystem.hpp"
#include "domain/RankExchange.hpp"
#include "kernels/coupling/Absorption.hpp"

namespace kf {

template <typename T>
class AbsorptionRanks {
public:
  /// Before the knit's points are shared out (KnitHalo::distribute): the absorption's columns
  /// travel with them from then on.
  AbsorptionRanks(RankExchange<T>& ranks, KnitHalo<T>& halo, KnitSystem<T>& knit,
                  ConservingAbsorption<T>& absorption);

  /// The stage's hooks for the fluid as it is now (collective from here: every rank runs the
  /// stage). The knit's ghosts are chosen first where a start or a re-partition dropped them.
  AbsorptionSplit<T> split(const exec::Exec& ex, FluidSet<T>& fluid);
  /// After absorb (collective): when any rank took a particle whole, the taken particles and all
  /// ghosts go (returns true: sort the fluid); else the ghosts of the particles that gave part
  /// of their mass take their owners' mass and acceleration.
  bool settle(const exec::Exec& ex, FluidSet<T>& fluid,
              const typename ConservingAbsorption<T>::Absorbed& got);
  /// After emit appended drops to the fluid (which then holds only the owned).
  void appended(const FluidSet<T>& fluid) { ranks_.appended(fluid); }

private:
  RankExchange<T>& ranks_;
  KnitHalo<T>& halo_;
  KnitSystem<T>& knit_;
  ConservingAbsorption<T>& absorption_;
};

} // namespace kf
