#include "domain/PairCostFit.hpp"

namespace kf {

void PairCostFit::add(double seconds_per_step, double points, double pairs) {
  pp_ += points * points;
  pq_ += points * pairs;
  qq_ += pairs * pairs;
  ps_ += points * seconds_per_step;
  qs_ += pairs * seconds_per_step;
  ++n_;
}

double PairCostFit::weight() const {
  const double scale = pp_ * qq_;
  const double det = scale - pq_ * pq_;
  if (!(scale > 0) || det <= kLeastSpread * scale)
    return 0.0;
  const double a = (qq_ * ps_ - pq_ * qs_) / det, b = (pp_ * qs_ - pq_ * ps_) / det;
  return a > 0 && b > 0 ? b / a : 0.0;
}

} // namespace kf
