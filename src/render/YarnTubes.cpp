#include "render/YarnTubes.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace kf::render {

namespace {

/// Any unit vector normal to t (unit).
glm::dvec3 some_normal(const glm::dvec3& t) {
  const glm::dvec3 axis = std::abs(t.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  return glm::normalize(glm::cross(t, axis));
}

/// Unit tangents of the chain x[a .. b]: central differences, one-sided at the ends; a point
/// that coincides with both neighbours keeps the previous tangent.
std::vector<glm::dvec3> tangents(const std::vector<glm::dvec3>& x, std::size_t a, std::size_t b) {
  std::vector<glm::dvec3> t(b - a + 1);
  glm::dvec3 last(1, 0, 0);
  for (std::size_t i = a; i <= b; ++i) {
    const glm::dvec3 d = x[std::min(i + 1, b)] - x[i > a ? i - 1 : a];
    const double len = glm::length(d);
    if (len > 0)
      last = d / len;
    t[i - a] = last;
  }
  return t;
}

} // namespace

namespace {

/// The chains and the drawn segments of n points: segment(i) its pair, position(i) its place.
template <typename Segment, typename Position>
YarnChains chains_of(std::size_t n, Segment&& segment, Position&& position, const Region* only,
                     double reach = 0) {
  // A segment within reach of the region: its points' box grown by reach meets the region's.
  const auto near = [&](std::size_t i) {
    const glm::dvec3 a = position(i), b = position(i + 1);
    return glm::all(glm::lessThan(glm::min(a, b) - reach, only->hi)) &&
           glm::all(glm::greaterThanEqual(glm::max(a, b) + reach, only->lo));
  };
  YarnChains c;
  for (std::size_t i = 0; i < n; ++i) {
    const auto& sg = segment(i);
    if (sg[0] != i || (sg[1] != i && sg[1] != i + 1) || sg[1] >= n)
      throw Error("render: yarn point " + std::to_string(i) + "'s segment (" +
                  std::to_string(sg[0]) + ", " + std::to_string(sg[1]) +
                  ") is not (i, i + 1) or (i, i)");
    if (i == 0 || segment(i - 1)[1] == i - 1)
      c.start.push_back(std::uint32_t(i));
    if (sg[1] == i + 1 && (!only || reach > 0 || only->contains(position(i))))
      c.drawn.push_back(std::uint32_t(i));
  }
  c.start.push_back(std::uint32_t(n));
  if (only && reach > 0) { // whole groups of the list, any of whose segments is near
    std::size_t kept = 0;
    const std::size_t g = kYarnGroup;
    for (std::size_t first = 0; first < c.drawn.size(); first += g) {
      const std::size_t last = std::min(first + g, c.drawn.size());
      bool any = false;
      for (std::size_t k = first; k < last && !any; ++k)
        any = near(c.drawn[k]);
      if (any)
        for (std::size_t k = first; k < last; ++k)
          c.drawn[kept++] = c.drawn[k];
    }
    c.drawn.resize(kept);
  }
  return c;
}

} // namespace

YarnChains yarn_chains(const YarnPolylines& y, const Region* only) {
  const std::size_t n = y.x.size();
  if (y.segment.size() != n || (!y.s.empty() && y.s.size() != n))
    throw Error("render: the yarn phase has " + std::to_string(n) + " positions but " +
                std::to_string(y.segment.size()) + " segments and " + std::to_string(y.s.size()) +
                " saturations");
  return chains_of(
      n, [&](std::size_t i) -> const auto& { return y.segment[i]; },
      [&](std::size_t i) { return y.x[i]; }, only);
}

YarnChains yarn_chains(const YarnPoints& y, const Region* only, double reach) {
  const std::size_t n = y.point.size();
  if (y.segment.size() != n)
    throw Error("render: the yarn phase has " + std::to_string(n) + " positions but " +
                std::to_string(y.segment.size()) + " segments");
  return chains_of(
      n, [&](std::size_t i) -> const auto& { return y.segment[i]; },
      [&](std::size_t i) { return glm::dvec3(glm::vec3(y.point[i])); }, only, reach);
}

YarnPoints yarn_points(const YarnPolylines& y) {
  YarnPoints p;
  p.segment = y.segment;
  p.point.resize(y.x.size());
  for (std::size_t i = 0; i < y.x.size(); ++i)
    p.point[i] = glm::vec4(glm::vec3(y.x[i]), y.s.empty() ? 0.0f : float(y.s[i]));
  return p;
}

YarnFrames yarn_frames(const YarnPolylines& y, const YarnStyle& style, const Region* only) {
  const std::size_t n = y.x.size();
  if (!(style.radius > 0) || style.sides < 3)
    throw Error("render: a yarn needs a radius > 0 and at least 3 sides");
  YarnChains chains_of = yarn_chains(y, only);
  const std::vector<std::uint32_t>& chain_start = chains_of.start;
  YarnFrames f;
  f.drawn = std::move(chains_of.drawn);
  f.centre_radius.resize(n);
  f.r_shade.resize(n);
  f.b.resize(n);
  const auto chains = std::ptrdiff_t(chain_start.size() - 1);
  // A yarn a thread: its frames run along it (a few hundred yarns in a garment).
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t c = 0; c < chains; ++c) {
    const std::size_t a = chain_start[std::size_t(c)], b = chain_start[std::size_t(c) + 1] - 1;
    const auto t = tangents(y.x, a, b);
    glm::dvec3 r = some_normal(t[0]);
    double arc = 0;
    for (std::size_t i = a; i <= b; ++i) {
      if (i > a)
        arc += glm::length(y.x[i] - y.x[i - 1]);
      if (i > a) { // double reflection: from the frame at i - 1 to the one at i
        const glm::dvec3 v1 = y.x[i] - y.x[i - 1];
        const double c1 = glm::dot(v1, v1);
        glm::dvec3 rl = r, tl = t[i - 1 - a];
        if (c1 > 0) {
          rl -= (2 / c1) * glm::dot(v1, r) * v1;
          tl -= (2 / c1) * glm::dot(v1, tl) * v1;
        }
        const glm::dvec3 v2 = t[i - a] - tl;
        const double c2 = glm::dot(v2, v2);
        r = c2 > 0 ? rl - (2 / c2) * glm::dot(v2, rl) * v2 : rl;
        // Rounding drift over thousands of points: back to unit and normal to the tangent.
        r = glm::normalize(r - glm::dot(r, t[i - a]) * t[i - a]);
      }
      const double s = y.s.empty() ? 0.0 : std::clamp(y.s[i], 0.0, 1.0);
      f.centre_radius[i] =
          glm::vec4(glm::vec3(y.x[i]), float(style.radius * (1 + style.swell * s)));
      f.r_shade[i] = glm::vec4(glm::vec3(r), float(1 - style.wet_darkening * std::sqrt(s)));
      f.b[i] = glm::vec4(glm::vec3(glm::cross(t[i - a], r)), float(arc));
    }
  }
  return f;
}

SurfaceMesh yarn_tubes(const YarnPolylines& y, const YarnStyle& style, const Region* only) {
  const YarnFrames f = yarn_frames(y, style, only);
  const std::size_t n = y.x.size(), sides = std::size_t(style.sides);
  SurfaceMesh m;
  m.position.resize(n * sides);
  m.normal.resize(n * sides);
  m.shade.resize(n * sides);
  const auto points = std::ptrdiff_t(n);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t p = 0; p < points; ++p) {
    const auto i = std::size_t(p);
    for (std::size_t k = 0; k < sides; ++k) {
      const double a = 2 * M_PI * double(k) / double(sides);
      const glm::vec3 out =
          float(std::cos(a)) * glm::vec3(f.r_shade[i]) + float(std::sin(a)) * glm::vec3(f.b[i]);
      m.position[i * sides + k] = glm::vec3(f.centre_radius[i]) + f.centre_radius[i].w * out;
      m.normal[i * sides + k] = out;
      m.shade[i * sides + k] = f.r_shade[i].w;
    }
  }
  // Two triangles a side a segment, counter-clockwise seen from outside: (ring k, ring k+1,
  // next k+1), (ring k, next k+1, next k).
  m.index.reserve(f.drawn.size() * 6 * sides);
  for (std::uint32_t i : f.drawn) {
    const auto ring = std::uint32_t(i * sides), next = std::uint32_t((i + 1) * sides);
    for (std::size_t k = 0; k < sides; ++k) {
      const auto k0 = std::uint32_t(k), k1 = std::uint32_t((k + 1) % sides);
      m.index.insert(m.index.end(),
                     {ring + k0, ring + k1, next + k1, ring + k0, next + k1, next + k0});
    }
  }
  return m;
}

} // namespace kf::render
