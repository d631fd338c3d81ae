#pragma once
// Where a frame's GPU time goes: GL timestamps written into the command stream between passes
// (glQueryCounter, each sent at once), read after the frame's read-back has waited for them
// anyway. A pass's time is the GPU's between its mark and the one before: its work, and any
// time the GPU waited for the host's next command.
#include <string>
#include <utility>
#include <vector>

namespace kf::render {

class GpuTimer {
public:
  /// Needs a current context.
  GpuTimer() = default;
  ~GpuTimer();
  GpuTimer(const GpuTimer&) = delete;
  GpuTimer& operator=(const GpuTimer&) = delete;

  /// Starts a frame's marks.
  void begin();
  /// The GPU's time at this point of the stream, ending the pass `label`.
  void mark(const char* label);
  /// Each pass's GPU seconds since begin(), in order (waits for the marks).
  std::vector<std::pair<std::string, double>> read();

private:
  std::vector<unsigned> queries_;
  std::vector<std::string> labels_;
  std::size_t used_ = 0;
};

/// "label seconds, ..." for a log line.
std::string format_passes(const std::vector<std::pair<std::string, double>>& passes);

} // namespace kf::render
