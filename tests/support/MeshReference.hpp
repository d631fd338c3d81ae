#pragma once
// Independent references for mesh obstacles: meshes generated in code (as OBJ text), and a
// brute-force signed distance that shares nothing with the library's: the distance by projecting
// onto each triangle's plane (else the nearest edge), the sign by the generalised winding number
// (the solid angle of all triangles, Van Oosterom & Strackee 1983) instead of pseudonormals.
#include "core/Vec3.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

namespace kf::test {

struct RefMesh {
  std::vector<Vec3d> x;
  std::vector<std::array<std::uint32_t, 3>> tri;
};

inline std::string obj_text(const std::vector<Vec3d>& x,
                            const std::vector<std::vector<std::uint32_t>>& faces) {
  std::string s;
  char buf[128];
  for (const Vec3d& p : x) {
    std::snprintf(buf, sizeof buf, "v %.17g %.17g %.17g\n", p.x, p.y, p.z);
    s += buf;
  }
  for (const auto& f : faces) {
    s += "f";
    for (std::uint32_t v : f) {
      s += ' ';
      s += std::to_string(v + 1);
    }
    s += "\n";
  }
  return s;
}

/// The box [lo, hi] as 12 triangles, wound outward.
inline std::string cube_obj(const Vec3d& lo, const Vec3d& hi) {
  std::vector<Vec3d> x;
  for (int k = 0; k < 8; ++k)
    x.push_back({k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z});
  // Each face as a quad (outward, counter-clockwise), split into two triangles.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  std::vector<std::vector<std::uint32_t>> f;
  for (const auto& q : quads) {
    f.push_back({std::uint32_t(q[0]), std::uint32_t(q[1]), std::uint32_t(q[2])});
    f.push_back({std::uint32_t(q[0]), std::uint32_t(q[2]), std::uint32_t(q[3])});
  }
  return obj_text(x, f);
}

/// An icosahedron subdivided `levels` times, vertices on the sphere (c, r), wound outward.
inline std::string icosphere_obj(int levels, const Vec3d& c, double r) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3d> u = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                          {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                          {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : u)
    p = p * (1 / norm(p));
  std::vector<std::array<std::uint32_t, 3>> f = {
      {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::vector<std::array<std::uint32_t, 3>> g;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> mids;
    auto mid = [&](std::uint32_t a, std::uint32_t b) {
      const std::uint64_t key = std::uint64_t(std::min(a, b)) << 32 | std::max(a, b);
      for (const auto& [k, v] : mids)
        if (k == key)
          return v;
      const Vec3d m = (u[a] + u[b]) * 0.5;
      u.push_back(m * (1 / norm(m)));
      mids.push_back({key, std::uint32_t(u.size() - 1)});
      return std::uint32_t(u.size() - 1);
    };
    for (const auto& [a, b, cc] : f) {
      const std::uint32_t ab = mid(a, b), bc = mid(b, cc), ca = mid(cc, a);
      g.push_back({a, ab, ca});
      g.push_back({b, bc, ab});
      g.push_back({cc, ca, bc});
      g.push_back({ab, bc, ca});
    }
    f = g;
  }
  std::vector<Vec3d> x;
  for (const Vec3d& p : u)
    x.push_back(c + p * r);
  std::vector<std::vector<std::uint32_t>> faces;
  for (const auto& t3 : f)
    faces.push_back({t3[0], t3[1], t3[2]});
  return obj_text(x, faces);
}

/// A torus about the z axis through c (radii R > r) of nu x nv quads, wound outward.
inline std::string torus_obj(const Vec3d& c, double R, double r, int nu, int nv) {
  std::vector<Vec3d> x;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double a = 2 * std::numbers::pi * i / nu, b = 2 * std::numbers::pi * j / nv;
      x.push_back(c + Vec3d{(R + r * std::cos(b)) * std::cos(a),
                            (R + r * std::cos(b)) * std::sin(a), r * std::sin(b)});
    }
  auto id = [&](int i, int j) { return std::uint32_t((i % nu) * nv + (j % nv)); };
  std::vector<std::vector<std::uint32_t>> faces;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j)
      faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)});
  return obj_text(x, faces);
}

/// Unsigned distance from p to triangle (a, b, c): to its plane when the foot lies inside it,
/// else to the nearest of its edges.
inline double ref_triangle_distance(const Vec3d& p, const Vec3d& a, const Vec3d& b,
                                    const Vec3d& c) {
  auto segment = [&](const Vec3d& s0, const Vec3d& s1) {
    const Vec3d d = s1 - s0;
    const double t = std::clamp(dot(p - s0, d) / std::max(norm2(d), 1e-300), 0.0, 1.0);
    return norm(p - (s0 + d * t));
  };
  const Vec3d n = cross(b - a, c - a);
  const double n2 = norm2(n);
  if (n2 > 0) {
    const Vec3d foot = p - n * (dot(p - a, n) / n2);
    // Inside when the foot is on the inner side of all three edges.
    if (dot(cross(b - a, foot - a), n) >= 0 && dot(cross(c - b, foot - b), n) >= 0 &&
        dot(cross(a - c, foot - c), n) >= 0)
      return norm(p - foot);
  }
  return std::min({segment(a, b), segment(b, c), segment(c, a)});
}

/// Winding number of the mesh about p: 1 inside a closed outward mesh, 0 outside.
inline double ref_winding_number(const RefMesh& m, const Vec3d& p) {
  double w = 0;
  for (const auto& t : m.tri) {
    const Vec3d a = m.x[t[0]] - p, b = m.x[t[1]] - p, c = m.x[t[2]] - p;
    const double la = norm(a), lb = norm(b), lc = norm(c);
    const double num = dot(a, cross(b, c));
    const double den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
    w += 2 * std::atan2(num, den);
  }
  return w / (4 * std::numbers::pi);
}

inline double ref_signed_distance(const RefMesh& m, const Vec3d& p) {
  double d = 1e300;
  for (const auto& t : m.tri)
    d = std::min(d, ref_triangle_distance(p, m.x[t[0]], m.x[t[1]], m.x[t[2]]));
  return ref_winding_number(m, p) > 0.5 ? -d : d;
}

} // namespace kf::test
