#pragma once
// Lanes (threads) a knit point in the knit's per-point passes on the GPU (for_each_lanes): the
// springs and volume cells, the self-contact and the coupling's knit side, alone or in the one
// force pass. One number for all of them: the one pass sums each term as its own pass does (to
// the bit), which takes the same lanes. Measured on the pour (docs/PERFORMANCE.md, P4 stage 2
// and P10): one lane a point left 50k points too few threads to hide their gathers; 2 and 8
// lanes made the one pass slower than 4 (23.4 -> 28.9 us at 8; 28 -> 33 us at 2 under ncu).

namespace kf {
inline constexpr unsigned kKnitLanes = 4;
} // namespace kf
