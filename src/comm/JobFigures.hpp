#pragma once
// A rank's figures reduced over the job together: each named once (summed, the most or the
// least), then one collective an operation writes the job's values back into them, where a
// collective a figure made a diagnostics output wait ~30 times.
#include "comm/MpiContext.hpp"

#include <cstdint>
#include <span>
#include <vector>

namespace kf::comm {

class JobFigures {
public:
  void sum(double& v) { sum_.push_back(&v); }
  void sum(std::uint64_t& v) { count_.push_back(&v); }
  void max(double& v) { max_.push_back(&v); }
  void min(double& v) { min_.push_back(&v); }

  /// The job's values into every figure named (collective: every rank names the same figures in
  /// the same order).
  void reduce(const MpiContext& mpi) {
    run(sum_, [&](std::span<double> v) { mpi.sum_in_place(v); });
    run(count_, [&](std::span<std::uint64_t> v) { mpi.sum_in_place(v); });
    run(max_, [&](std::span<double> v) { mpi.max_in_place(v); });
    run(min_, [&](std::span<double> v) { mpi.min_in_place(v); });
  }

private:
  template <typename V, typename Op>
  static void run(std::vector<V*>& refs, Op op) {
    if (refs.empty())
      return;
    std::vector<V> values;
    values.reserve(refs.size());
    for (V* r : refs)
      values.push_back(*r);
    op(std::span<V>(values));
    for (std::size_t k = 0; k < refs.size(); ++k)
      *refs[k] = values[k];
    refs.clear();
  }
  std::vector<double*> sum_, max_, min_;
  std::vector<std::uint64_t*> count_;
};

} // namespace kf::comm
