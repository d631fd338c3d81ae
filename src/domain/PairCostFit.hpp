#pragma once
// What a knit-fluid coupling pair costs beside a knit point, measured by the run (DESIGN §6: a
// block weighed by its measured cost). The coupling's work sits on the wet points (each walks
// its listed fluid pairs in every substep; the fluid side walks the same pairs), so a count of
// knit points a block misses it: the coupled pour on 2 ranks had 1,072 of its 1,100 contacts on
// one rank (docs/PERFORMANCE.md, "P5: the coupling's pairs weighed in the blocks' counts").
//
// Each imbalance check gives one sample a rank: its knit seconds a step since the last check,
// its knit points and the pairs listed for them. The fit is the least-squares solution of
// seconds = a * points + b * pairs over every sample since the start (no intercept: a rank
// without knit spends nothing on it); the pairs' weight is b / a, a pair in knit points. Host
// arithmetic, no MPI: every rank adds the job's samples in the same order and gets the same
// weight.
#include <cstddef>

namespace kf {

class PairCostFit {
public:
  /// One rank's interval: knit seconds a step, knit points, coupling pairs listed for them.
  void add(double seconds_per_step, double points, double pairs);
  /// A pair's cost in knit points (b / a); 0 until the samples determine it: pairs on too few
  /// of them, or in the same proportion to the points on each (the normal equations'
  /// determinant under kLeastSpread of its largest part), or a fit that is not positive in both
  /// (noise larger than the pairs' cost).
  double weight() const;
  std::size_t samples() const { return n_; }
  /// The least relative spread of the samples' pairs against their points (the determinant
  /// over sum(points^2) sum(pairs^2)) for the fit to stand: below it the pairs' part is not
  /// told apart from the points' (1% of the determinant's scale: pairs in one rank's samples
  /// only, as a stream landing on one side, give ~50%).
  static constexpr double kLeastSpread = 0.01;

private:
  double pp_ = 0, pq_ = 0, qq_ = 0, ps_ = 0, qs_ = 0;
  std::size_t n_ = 0;
};

} // namespace kf
