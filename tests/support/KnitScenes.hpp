#pragma once
// Small knit scenes shared by the tests.
#include "domain/Scene.hpp"

#include <cmath>

namespace kf::test {

/// A strip 4 cm wide (6 wales), `length` m tall, leaning 0.2 along x, its foot `foot` m above
/// the floor, in a slot as wide as the strip: dropped, it crumples onto the floor in folds in the
/// x-z plane that land on each other (self-collision). Float, no output.
inline Scene falling_strip(double length, int courses, double foot, bool self_collision = true) {
  Scene s;
  s.name = "fold";
  s.modules = {Module::Knit};
  s.domain.min = {-0.35, -0.024, 0};
  s.domain.max = {0.35, 0.024, 0.7};
  s.output.enabled = false;
  s.precision = Precision::Float;
  KnitPiece p;
  p.name = "strip";
  p.center = {0.03, 0, foot + 0.5 * length};
  p.normal = {1, 0, 0.2}; // leaning: the strip's length runs along v = n x u = (-0.2, 0, 1)
  p.u_axis = {0, 1, 0};
  p.width = 0.04;
  p.height = length / std::cos(std::atan(0.2)); // vertical extent `length`
  p.wales = 6;
  p.courses = courses;
  s.knit.pieces = {p};
  s.knit.thickness = 0.003;
  s.knit.mass_per_area = 0.3;
  s.knit.stretch = 150;
  s.knit.shear = 8;
  s.knit.bend = 0.5;
  s.knit.compression = 3000;
  s.knit.layer_shear = 1500;
  s.knit.damping_ratio = 0.2;
  s.knit.friction = 0.5;
  s.knit.self_collision = self_collision;
  return s;
}

} // namespace kf::test
