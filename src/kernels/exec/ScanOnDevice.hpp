#pragma once
// An exclusive scan whose total stays on the device: for counts the host needs only later (a
// buffer's size for the next build, read behind the work: PendingRead), where exclusive_scan's
// returned total would wait for the device.
#include "kernels/exec/Algorithms.hpp"

namespace kf::exec {

/// The sum of all n inputs of an exclusive scan, from its last input and output (0 for none):
/// what exclusive_scan_on_device writes to its total, for a pass after a scan that skipped it.
KF_HD inline std::uint32_t exclusive_scan_total(const std::uint32_t* in, const std::uint32_t* out,
                                                std::size_t n) {
  return n ? out[n - 1] + in[n - 1] : 0u;
}

/// out[i] = sum of in[0..i), and *total (device memory on ex.backend) the sum of all; nothing
/// is read on the host. A null total skips it (one launch fewer: a caller's next pass can take
/// it from exclusive_scan_total). out must not alias in; the sum must fit in 32 bits.
void exclusive_scan_on_device(const Exec& ex, const DeviceBuffer<std::uint32_t>& in,
                              DeviceBuffer<std::uint32_t>& out, std::uint32_t* total,
                              const char* label);

} // namespace kf::exec
