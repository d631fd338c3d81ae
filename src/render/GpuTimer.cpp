#include "render/GpuTimer.hpp"

#include <epoxy/gl.h>

#include <cstdio>

namespace kf::render {

GpuTimer::~GpuTimer() {
  if (!queries_.empty())
    glDeleteQueries(GLsizei(queries_.size()), queries_.data());
}

void GpuTimer::begin() {
  used_ = 0;
  labels_.clear();
  mark("");
}

void GpuTimer::mark(const char* label) {
  if (used_ == queries_.size()) {
    unsigned q = 0;
    glGenQueries(1, &q);
    queries_.push_back(q);
  }
  glQueryCounter(queries_[used_++], GL_TIMESTAMP);
  // Sent now: a query left in the driver's command buffer would be stamped when the next flush
  // sends it, charging the host's work after it to this pass.
  glFlush();
  labels_.emplace_back(label);
}

std::vector<std::pair<std::string, double>> GpuTimer::read() {
  std::vector<std::pair<std::string, double>> passes;
  GLuint64 last = 0;
  for (std::size_t i = 0; i < used_; ++i) {
    GLuint64 t = 0;
    glGetQueryObjectui64v(queries_[i], GL_QUERY_RESULT, &t);
    if (i > 0)
      passes.emplace_back(labels_[i], double(t - last) * 1e-9);
    last = t;
  }
  return passes;
}

std::string format_passes(const std::vector<std::pair<std::string, double>>& passes) {
  std::string s;
  for (const auto& [label, seconds] : passes) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%s%s %.4f", s.empty() ? "" : ", ", label.c_str(), seconds);
    s += buf;
  }
  return s;
}

} // namespace kf::render
