#include "render/FluidSurface.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <unordered_map>

namespace kf::render {

double SurfaceMesh::area() const {
  double a = 0;
  for (std::size_t t = 0; t + 2 < index.size(); t += 3) {
    const glm::dvec3 p0(position[index[t]]), p1(position[index[t + 1]]), p2(position[index[t + 2]]);
    a += 0.5 * glm::length(glm::cross(p1 - p0, p2 - p0));
  }
  return a;
}

namespace {

/// The 3-D cubic spline of support 2 h (Monaghan), integral 1.
double cubic_spline(double r, double h) {
  const double q = r / h, sigma = 1.0 / (std::numbers::pi * h * h * h);
  if (q < 1)
    return sigma * (1 - 1.5 * q * q + 0.75 * q * q * q);
  if (q < 2)
    return sigma * 0.25 * (2 - q) * (2 - q) * (2 - q);
  return 0;
}

} // namespace

ParticleBins::ParticleBins(const std::vector<glm::dvec3>& p, glm::dvec3 lo_, glm::dvec3 hi,
                           double size_)
    : lo(lo_), size(size_) {
  for (int a = 0; a < 3; ++a)
    n[std::size_t(a)] = std::max(1, int(std::ceil((hi[a] - lo[a]) / size)));
  start.assign(std::size_t(n[0]) * n[1] * n[2] + 1, 0);
  std::vector<std::uint32_t> bin(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    bin[i] = std::uint32_t(index(cell_of(p[i])));
    ++start[bin[i] + 1];
  }
  for (std::size_t b = 1; b < start.size(); ++b)
    start[b] += start[b - 1];
  item.resize(p.size());
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (std::size_t i = 0; i < p.size(); ++i)
    item[fill[bin[i]]++] = std::uint32_t(i);
}

std::array<int, 3> ParticleBins::cell_of(const glm::dvec3& x) const {
  std::array<int, 3> c;
  for (int a = 0; a < 3; ++a)
    c[std::size_t(a)] =
        std::clamp(int(std::floor((x[a] - lo[a]) / size)), 0, n[std::size_t(a)] - 1);
  return c;
}

ScalarGrid surface_grid(const std::vector<glm::dvec3>& points, const SurfaceOptions& opt) {
  if (!(opt.spacing > 0) || !(opt.cell > 0) || !(opt.support > 0))
    throw Error("fluid surface: spacing, cell and support must be positive");
  ScalarGrid g;
  if (points.empty())
    return g;
  const double dp = opt.spacing, reach = opt.support * dp;
  glm::dvec3 lo(points[0]), hi(points[0]);
  if (opt.box) {
    lo = opt.box->first;
    hi = opt.box->second;
  } else {
    for (const auto& p : points) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  }
  // A margin past the kernel's reach: the field is negative on the grid's border, so the surface
  // closes inside it.
  lo -= glm::dvec3(reach + dp);
  hi += glm::dvec3(reach + dp);
  double cell = opt.cell * dp;
  auto count = [&](double c) {
    double v = 1;
    for (int a = 0; a < 3; ++a)
      v *= std::ceil((hi[a] - lo[a]) / c) + 1;
    return v;
  };
  while (count(cell) > double(opt.max_cells))
    cell *= 1.25;
  g.origin = lo;
  g.cell = cell;
  for (int a = 0; a < 3; ++a)
    g.n[std::size_t(a)] = int(std::ceil((hi[a] - lo[a]) / cell)) + 1;
  return g;
}

ScalarGrid surface_field(const std::vector<glm::dvec3>& points, const SurfaceOptions& opt,
                         const Region* only) {
  ScalarGrid g = surface_grid(points, opt);
  if (points.empty())
    return g;
  const double dp = opt.spacing, reach = opt.support * dp, cell = g.cell;
  const glm::dvec3 lo = g.origin, hi = lo + cell * glm::dvec3(g.n[0] - 1, g.n[1] - 1, g.n[2] - 1);
  g.value.assign(std::size_t(g.n[0]) * g.n[1] * g.n[2], 0.0f);
  const ParticleBins bins(points, lo, hi, reach);
  const double volume = dp * dp * dp, r2max = reach * reach, radius = opt.radius * dp;
  Region near;
  if (only)
    near = {only->lo - glm::dvec3(2 * cell), only->hi + glm::dvec3(2 * cell)};
  const long long total = (long long)g.value.size();
#pragma omp parallel for schedule(static)
  for (long long v = 0; v < total; ++v) {
    const long long i = v % g.n[0], j = (v / g.n[0]) % g.n[1], k = v / (g.n[0] * (long long)g.n[1]);
    const glm::dvec3 x = lo + cell * glm::dvec3(double(i), double(j), double(k));
    if (only && !near.contains(x)) {
      g.value[std::size_t(v)] = float(-reach);
      continue;
    }
    if (opt.field == SurfaceField::Naive) {
      double sum = 0;
      bins.around(x, [&](std::uint32_t p) {
        const glm::dvec3 d = x - points[p];
        const double r2 = glm::dot(d, d);
        if (r2 < r2max)
          sum += volume * cubic_spline(std::sqrt(r2), 0.5 * reach);
      });
      g.value[std::size_t(v)] = float(sum - 0.5);
    } else {
      double wsum = 0;
      glm::dvec3 mean(0);
      bins.around(x, [&](std::uint32_t p) {
        const glm::dvec3 d = x - points[p];
        const double s = 1 - glm::dot(d, d) / r2max;
        if (s > 0) {
          const double w = s * s * s;
          wsum += w;
          mean += w * points[p];
        }
      });
      g.value[std::size_t(v)] =
          wsum > 0 ? float(radius - glm::length(x - mean / wsum)) : float(-reach);
    }
  }
  return g;
}

namespace {

/// Triangles of each of the 256 corner cases, as cube edges (0-11).
struct CaseTable {
  std::array<std::pair<int, int>, 12> edge; // corner pairs, corner bit b = x | y << 1 | z << 2
  std::array<std::vector<std::array<int, 3>>, 256> triangles;

  CaseTable() {
    int e = 0;
    int id[8][8];
    for (int a = 0; a < 8; ++a)
      for (int bit = 1; bit < 8; bit <<= 1)
        if (!(a & bit)) {
          edge[std::size_t(e)] = {a, a | bit};
          id[a][a | bit] = id[a | bit][a] = e++;
        }
    // Each face's corners in counter-clockwise order seen from outside the cube.
    std::array<std::array<int, 4>, 6> face;
    for (int axis = 0, f = 0; axis < 3; ++axis)
      for (int side = 0; side < 2; ++side, ++f) {
        const int u = 1 << ((axis + 1) % 3), v = 1 << ((axis + 2) % 3), w = side << axis;
        // (u, v, u x v = +axis) counter-clockwise from +axis: (0,0), (1,0), (1,1), (0,1).
        std::array<int, 4> q = {w, w | u, w | u | v, w | v};
        if (side == 0)
          std::reverse(q.begin(), q.end());
        face[std::size_t(f)] = q;
      }
    for (int m = 0; m < 256; ++m) {
      int next[12];
      std::fill(next, next + 12, -1);
      for (const auto& q : face) {
        auto in = [&](int k) { return (m >> q[std::size_t((k + 4) % 4)]) & 1; };
        for (int k = 0; k < 4; ++k) {
          if (!in(k) || in(k - 1))
            continue; // not the first corner of a run of inside corners
          int j = k;
          while (in(j + 1) && j + 1 < k + 4)
            ++j;
          const int entry = id[q[std::size_t((k + 3) % 4)]][q[std::size_t(k)]];
          const int exit = id[q[std::size_t(j % 4)]][q[std::size_t((j + 1) % 4)]];
          next[entry] = exit;
        }
      }
      bool used[12] = {};
      for (int s = 0; s < 12; ++s) {
        if (next[s] < 0 || used[s])
          continue;
        std::vector<int> loop;
        for (int c = s; !used[c]; c = next[c]) {
          used[c] = true;
          loop.push_back(c);
        }
        for (std::size_t t = 1; t + 1 < loop.size(); ++t)
          triangles[std::size_t(m)].push_back({loop[0], loop[t], loop[t + 1]});
      }
    }
    // Orientation: corner 0 alone inside, its triangle's normal must point away from it.
    auto mid = [&](int ed) {
      const auto [a, b] = edge[std::size_t(ed)];
      return 0.5f * (glm::vec3(a & 1, (a >> 1) & 1, (a >> 2) & 1) +
                     glm::vec3(b & 1, (b >> 1) & 1, (b >> 2) & 1));
    };
    const auto& t0 = triangles[1].at(0);
    const glm::vec3 n = glm::cross(mid(t0[1]) - mid(t0[0]), mid(t0[2]) - mid(t0[0]));
    if (glm::dot(n, glm::vec3(1)) < 0)
      for (auto& list : triangles)
        for (auto& t : list)
          std::swap(t[1], t[2]);
  }
};

const CaseTable& cases() {
  static const CaseTable table;
  return table;
}

} // namespace

const MarchingCubesTable& marching_cubes_table() {
  static const MarchingCubesTable flat = [] {
    const CaseTable& t = cases();
    MarchingCubesTable f;
    std::size_t most = 0;
    for (const auto& list : t.triangles)
      most = std::max(most, list.size());
    f.stride = int(1 + 3 * most);
    f.cases.assign(256 * std::size_t(f.stride), 0);
    for (std::size_t m = 0; m < 256; ++m) {
      int* row = f.cases.data() + m * std::size_t(f.stride);
      row[0] = int(t.triangles[m].size());
      for (std::size_t k = 0; k < t.triangles[m].size(); ++k)
        for (std::size_t c = 0; c < 3; ++c)
          row[1 + 3 * k + c] = t.triangles[m][k][c];
    }
    for (std::size_t e = 0; e < 12; ++e) {
      f.edge_corners[2 * e] = t.edge[e].first;
      f.edge_corners[2 * e + 1] = t.edge[e].second;
    }
    return f;
  }();
  return flat;
}

SurfaceMesh marching_cubes(const ScalarGrid& g, const Region* only) {
  SurfaceMesh mesh;
  const auto& table = cases();
  const int nx = g.n[0], ny = g.n[1], nz = g.n[2];
  if (nx < 2 || ny < 2 || nz < 2)
    return mesh;
  auto vid = [&](int i, int j, int k) {
    return std::size_t(i) + std::size_t(nx) * (std::size_t(j) + std::size_t(ny) * std::size_t(k));
  };
  auto gradient = [&](int i, int j, int k) {
    auto d = [&](int a) {
      int lo[3] = {i, j, k}, hi[3] = {i, j, k};
      lo[a] = std::max(0, lo[a] - 1);
      hi[a] = std::min(g.n[std::size_t(a)] - 1, hi[a] + 1);
      return double(g.at(hi[0], hi[1], hi[2]) - g.at(lo[0], lo[1], lo[2])) /
             ((hi[a] - lo[a]) * g.cell);
    };
    return glm::dvec3(d(0), d(1), d(2));
  };
  std::unordered_map<std::uint64_t, std::uint32_t> vertex_of_edge;
  auto vertex = [&](int i, int j, int k, int corner_a, int corner_b) {
    const int a[3] = {i + (corner_a & 1), j + ((corner_a >> 1) & 1), k + ((corner_a >> 2) & 1)};
    const int b[3] = {i + (corner_b & 1), j + ((corner_b >> 1) & 1), k + ((corner_b >> 2) & 1)};
    const int axis = (corner_a ^ corner_b) == 1 ? 0 : ((corner_a ^ corner_b) == 2 ? 1 : 2);
    const std::uint64_t key =
        3 * std::uint64_t(vid(std::min(a[0], b[0]), std::min(a[1], b[1]), std::min(a[2], b[2]))) +
        std::uint64_t(axis);
    const auto [it, fresh] = vertex_of_edge.try_emplace(key, std::uint32_t(mesh.position.size()));
    if (fresh) {
      const double fa = g.at(a[0], a[1], a[2]), fb = g.at(b[0], b[1], b[2]);
      const double t = fa / (fa - fb);
      const glm::dvec3 pa = g.origin + g.cell * glm::dvec3(a[0], a[1], a[2]);
      const glm::dvec3 pb = g.origin + g.cell * glm::dvec3(b[0], b[1], b[2]);
      const glm::dvec3 grad = (1 - t) * gradient(a[0], a[1], a[2]) + t * gradient(b[0], b[1], b[2]);
      const double len = glm::length(grad);
      mesh.position.push_back(glm::vec3(pa + t * (pb - pa)));
      // The field rises into the fluid: outward is down its gradient.
      mesh.normal.push_back(len > 0 ? glm::vec3(-grad / len) : glm::vec3(0, 0, 1));
    }
    return it->second;
  };
  for (int k = 0; k + 1 < nz; ++k)
    for (int j = 0; j + 1 < ny; ++j)
      for (int i = 0; i + 1 < nx; ++i) {
        if (only && !only->contains(g.origin + g.cell * glm::dvec3(i + 0.5, j + 0.5, k + 0.5)))
          continue;
        int m = 0;
        for (int c = 0; c < 8; ++c)
          if (g.at(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)) > 0)
            m |= 1 << c;
        for (const auto& t : table.triangles[std::size_t(m)])
          for (int e : t) {
            const auto [ca, cb] = table.edge[std::size_t(e)];
            mesh.index.push_back(vertex(i, j, k, ca, cb));
          }
      }
  return mesh;
}

} // namespace kf::render
