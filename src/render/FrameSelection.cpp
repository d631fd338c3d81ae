#include "render/FrameSelection.hpp"

#include "core/Error.hpp"

#include <regex>
#include <stdexcept>

namespace kf::render {

std::vector<std::uint64_t> select_frames(const std::string& spec,
                                         const std::vector<std::uint64_t>& available) {
  static const std::regex form(R"(^\s*(\d*)\s*(?::\s*(\d*)\s*(?::\s*(\d*)\s*)?)?$)");
  std::smatch m;
  if (!std::regex_match(spec, m, form))
    throw InputError("--frames '" + spec +
                     "': expected A:B:S (first frame, last frame, step; each may be "
                     "left out), e.g. 0:100:5");
  if (available.empty())
    return {};
  const bool single = m[2].matched == false; // "A" alone: that frame
  std::uint64_t first = 0, last = 0, step = 1;
  try {
    first = m[1].length() ? std::stoull(m[1]) : available.front();
    last = single && m[1].length() ? first : (m[2].length() ? std::stoull(m[2]) : available.back());
    step = m[3].length() ? std::stoull(m[3]) : 1;
  } catch (const std::out_of_range&) {
    throw InputError("--frames '" + spec + "': a number is too large");
  }
  if (step == 0)
    throw InputError("--frames '" + spec + "': the step must be at least 1");
  std::vector<std::uint64_t> out;
  for (std::uint64_t f : available)
    if (f >= first && f <= last && (f - first) % step == 0)
      out.push_back(f);
  return out;
}

} // namespace kf::render
