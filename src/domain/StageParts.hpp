#pragma once
// Timing of the parts inside a pipeline stage (the knit's substeps: integration and contact with
// solids, springs, self-contact, coupling), for `run --profile`. Off, a part costs one branch;
// on, it waits for the device before and after, so the parts add up to the stage's time.
#include "kernels/exec/Backend.hpp"

#include <string>
#include <utility>
#include <vector>

namespace kf::stage_parts {

/// Turns timing on or off for the process; `backend` is synchronised around each part.
void enable(bool on, exec::Backend backend);
bool enabled();
/// Seconds per part name, in the order the parts were first seen.
std::vector<std::pair<std::string, double>> totals();

/// Adds the time from construction to destruction to `name` (a string literal).
class Scope {
public:
  explicit Scope(const char* name);
  ~Scope();
  Scope(const Scope&) = delete;
  Scope& operator=(const Scope&) = delete;

private:
  const char* name_ = nullptr;
  double start_ = 0;
};

} // namespace kf::stage_parts
