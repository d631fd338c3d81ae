#pragma once
// Which of a run's frames to draw: `--frames A:B:S`.
#include <cstdint>
#include <string>
#include <vector>

namespace kf::render {

/// The frame indices among `available` (ascending) from A to B inclusive, every S from A: each
/// part may be left out (the first, the last, 1); "A" alone is that frame. A malformed spec or a
/// step of 0 is a kf::InputError naming it and what was expected.
std::vector<std::uint64_t> select_frames(const std::string& spec,
                                         const std::vector<std::uint64_t>& available);

} // namespace kf::render
