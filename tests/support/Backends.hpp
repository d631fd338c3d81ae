#pragma once
// The backends a test runs its cases on: the CPU, and CUDA where a GPU is visible.
#include "kernels/exec/Backend.hpp"

#include <vector>

namespace kf::test {

inline std::vector<exec::Backend> backends() {
  std::vector<exec::Backend> b{exec::Backend::Cpu};
  if (exec::cuda_available())
    b.push_back(exec::Backend::Cuda);
  return b;
}

} // namespace kf::test
