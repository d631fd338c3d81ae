#pragma once
#include "domain/RankExchange.hpp"

namespace kf {

/// Times a pass of local work (one that waits for no other rank) for the ranks' imbalance, until
/// stop() or the end of the scope; nothing on one rank. On a device the time is the stream's
/// between two events, read at the imbalance check: the host does not wait for the pass here.
template <typename T>
class LocalWork {
public:
  explicit LocalWork(RankExchange<T>* ranks, Phase phase = Phase::Fluid)
      : ranks_(ranks), phase_(phase), exchange0_(ranks ? ranks->exchange_seconds() : 0.0) {
    if (ranks_)
      ranks_->clock(phase_).start();
  }
  ~LocalWork() { stop(); }
  void stop() const {
    if (!ranks_)
      return;
    ranks_->clock(phase_).stop();
    // Less the exchanges inside the scope (the knit's ghost refreshes between substeps, timed
    // on the host: each waits for its rows, so the device idles for about as long).
    const double waited = ranks_->exchange_seconds() - exchange0_;
    if (waited > 0)
      ranks_->add_compute(-waited, phase_);
    ranks_ = nullptr;
  }

private:
  mutable RankExchange<T>* ranks_;
  Phase phase_;
  double exchange0_;
};

} // namespace kf
