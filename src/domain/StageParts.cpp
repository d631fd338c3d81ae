#include "domain/StageParts.hpp"

#include <chrono>
#include <cstring>

namespace kf::stage_parts {

namespace {

bool g_on = false;
exec::Backend g_backend = exec::Backend::Cpu;
std::vector<std::pair<std::string, double>> g_totals;

double now() {
  using clock = std::chrono::steady_clock;
  return std::chrono::duration<double>(clock::now().time_since_epoch()).count();
}

} // namespace

void enable(bool on, exec::Backend backend) {
  g_on = on;
  g_backend = backend;
}

bool enabled() {
  return g_on;
}

std::vector<std::pair<std::string, double>> totals() {
  return g_totals;
}

Scope::Scope(const char* name) {
  if (!g_on)
    return;
  name_ = name;
  exec::synchronize(g_backend);
  start_ = now();
}

Scope::~Scope() {
  if (!name_)
    return;
  exec::synchronize(g_backend);
  const double dt = now() - start_;
  for (auto& [n, s] : g_totals)
    if (n == name_) {
      s += dt;
      return;
    }
  g_totals.emplace_back(name_, dt);
}

} // namespace kf::stage_parts
