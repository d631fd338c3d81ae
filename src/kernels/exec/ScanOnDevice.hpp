#pragma once
// An exclusive scan whose total stays on the device: for counts the host needs only later (a
// buffer's size for the next build, read behind the work: PendingRead), where exclusive_scan's
// returned total would wait for the device.
#include "kernels/exec/Algorithms.hpp"

namespace kf::exec {

/// out[i] = sum of in[0..i), and *total (device memory on ex.backend) the sum of all; nothing
/// is read on the host. A null total skips it (one launch fewer: a caller's next pass can take
/// it as out[n-1] + in[n-1]). out must not alias in; the sum must fit in 32 bits.
void exclusive_scan_on_device(const Exec& ex, const DeviceBuffer<std::uint32_t>& in,
                              DeviceBuffer<std::uint32_t>& out, std::uint32_t* total,
                              const char* label);

} // namespace kf::exec
