#pragma once
// The watchdog tests' shared pieces (test_watchdog, test_watchdog_mpi): the coupling tests'
// patch and fluid block under gravity, and a frame's rows summed on the host, the independent
// reference for Simulation::watch().
#include "domain/Scene.hpp"
#include "io/Frame.hpp"
#include "support/CouplingScenes.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace kf::test {

/// The coupling tests' patch and a fluid block falling onto it, under gravity, in double.
inline Scene falling_coupled_scene() {
  std::string text = scene_text(R"("fluid", "boundary", "knit", "contact")",
                                "min = [-0.02, -0.02, 0.07]\nmax = [0.02, 0.02, 0.11]", -0.5);
  text.replace(text.find("gravity = [0, 0, 0]"), 19, "gravity = [0, 0, -9.81]");
  return parse_scene(text, "watch");
}

/// A frame's fluid and knit rows (double precision) summed and maximised on the host, heights
/// above z = floor under gravity g along -z.
struct FrameSums {
  double mass = 0, knit_mass = 0, kinetic = 0, potential = 0;
  double fluid_max_speed = 0, knit_max_speed = 0, fluid_max_density = 0;
  std::size_t rows = 0, fluid_rows = 0, knit_rows = 0;
};

inline FrameSums frame_sums(const io::Frame& fr, double g, double floor) {
  FrameSums s;
  for (const char* phase : {"fluid", "knit"}) {
    const io::Phase& ph = *fr.find(phase);
    const bool fluid = phase[0] == 'f';
    const auto x = ph.find("position")->as<double>();
    const auto v = ph.find("velocity")->as<double>();
    const auto m = ph.find("mass")->as<double>();
    s.rows += m.size();
    (fluid ? s.fluid_rows : s.knit_rows) += m.size();
    for (std::size_t i = 0; i < m.size(); ++i) {
      const double v2 =
          v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2];
      s.mass += m[i];
      if (!fluid)
        s.knit_mass += m[i];
      s.kinetic += 0.5 * m[i] * v2;
      s.potential += m[i] * g * (x[3 * i + 2] - floor);
      double& top = fluid ? s.fluid_max_speed : s.knit_max_speed;
      top = std::max(top, std::sqrt(v2));
    }
    if (fluid)
      for (double d : ph.find("density")->as<double>())
        s.fluid_max_density = std::max(s.fluid_max_density, d);
  }
  return s;
}

} // namespace kf::test
