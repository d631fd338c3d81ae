#include "domain/SceneSampler.hpp"

#include "core/Error.hpp"
#include "domain/LatticeSieve.hpp"
#include "domain/RigidShapes.hpp"
#include "domain/Samplers.hpp"
#include "domain/ShapeBounds.hpp"
#include "kernels/particles/FluidSet.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace kf {

namespace {

int cells_along(double length, double dp) {
  return std::max(0, static_cast<int>(std::floor(length / dp + 1e-9)));
}

/// A number in [-0.5, 0.5) from a lattice point and an axis (splitmix64's finaliser): the
/// jitter depends on nothing but the point, so every run and rank samples the same start.
double jitter_of(std::uint64_t point, int axis) {
  std::uint64_t z = point * 3 + static_cast<std::uint64_t>(axis) + 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53 - 0.5;
}

/// Boundary lattice coordinates along one axis of the domain [lo, hi], with the spacing each
/// point stands for. Inside, n = round((hi - lo) / dp) points evenly over the domain (spacing
/// (hi - lo) / n, which is dp when the domain is a multiple of dp); outside each face, layers at
/// (k + 1/2) dp from that face. So every wall has its first layer half a spacing behind it and no
/// hole, whatever the domain's size (a gap there lets fluid sink through the floor).
struct AxisLattice {
  std::vector<double> x, spacing;
};

AxisLattice axis_lattice(double lo, double hi, double dp, double depth) {
  AxisLattice a;
  const int layers = static_cast<int>(std::ceil(depth / dp - 1e-9));
  const int n = std::max(1, static_cast<int>(std::lround((hi - lo) / dp)));
  const double s = (hi - lo) / n;
  auto add = [&](double x, double w) {
    a.x.push_back(x);
    a.spacing.push_back(w);
  };
  for (int k = layers - 1; k >= 0; --k)
    add(lo - (k + 0.5) * dp, dp);
  for (int i = 0; i < n; ++i)
    add(lo + (i + 0.5) * s, s);
  for (int k = 0; k < layers; ++k)
    add(hi + (k + 0.5) * dp, dp);
  return a;
}

// A box's class for the fluid's carving (a point is kept where every solid lies at least keep
// away); and the boundary's, where shape s's shell holds every point: kAllOf + s.
constexpr std::uint8_t kFree = 0, kCarved = 1, kNone = 254, kAllOf = 0;

/// The bounds decide a point only this far inside an outcome: the distances at the points, each
/// rounded, cannot then cross an edge the bound put them beyond (rounding is ~1e-16 of a
/// coordinate).
double decided_by(double dp) {
  return 1e-6 * dp;
}

constexpr int kSlab = 16; // layers classified at once (memory: a byte a point of a slab)

/// A fluid block's lattice: points at cell centres, each moved by its own jitter, kept where
/// every solid lies at least dp / 4 away (carve: the boundary is on).
struct BlockLattice {
  std::unique_ptr<LatticeSieve> sieve;
  int first_layer = 0;
  const std::vector<RigidShape<double>>* shapes;
  bool carve;
  double keep, dp, amplitude;
  Vec3d min, velocity;
  int nx, ny;
  std::uint64_t* tested;

  static bool samples_at(std::uint8_t c) { return c == kFree; }
  /// Fills s (but its id) where point (i, j, k) of class c is a sample (kSieveMaybe: decided
  /// by its own distances).
  bool make(int i, int j, int k, std::uint8_t c, Sample& s) const {
    if (c == kCarved)
      return false;
    Vec3d p = min + Vec3d{(i + 0.5) * dp, (j + 0.5) * dp, (k + 0.5) * dp};
    if (amplitude > 0) {
      const std::uint64_t q = (std::uint64_t(k) * ny + j) * nx + i;
      p += Vec3d{amplitude * jitter_of(q, 0), amplitude * jitter_of(q, 1),
                 amplitude * jitter_of(q, 2)};
    }
    if (c == kSieveMaybe && carve) {
      ++*tested;
      for (const auto& shape : *shapes) {
        Vec3d normal;
        if (!(shape.distance(p, normal) >= keep))
          return false;
      }
    }
    s.x = p;
    s.v = velocity;
    return true;
  }
};

/// The boundary's lattice: a point is shape s's where s is the first whose shell (-depth <= d
/// < 0) holds it.
struct WallLattice {
  std::unique_ptr<LatticeSieve> sieve;
  int first_layer = 0;
  const std::vector<RigidShape<double>>* shapes;
  AxisLattice ax, ay, az;
  std::size_t container;
  double depth, dp;
  std::uint64_t* tested;

  static bool samples_at(std::uint8_t c) { return c != kNone; }
  bool make(int i, int j, int k, std::uint8_t c, Sample& out) const {
    if (c == kNone)
      return false;
    const Vec3d p{ax.x[i], ay.x[j], az.x[k]};
    std::size_t s = c - kAllOf;
    if (c == kSieveMaybe) {
      ++*tested;
      for (s = 0; s < shapes->size(); ++s) {
        Vec3d n;
        const double d = (*shapes)[s].distance(p, n);
        if (d < 0 && d >= -depth)
          break;
      }
      if (s == shapes->size())
        return false;
    }
    out.x = p;
    out.obstacle = s == container ? kWallObstacle : static_cast<std::uint32_t>(s);
    out.volume_scale = ax.spacing[i] * ay.spacing[j] * az.spacing[k] / (dp * dp * dp);
    return true;
  }
};

/// Adds each row's samples over `box` to row(j, k), testing only the undecided points.
template <typename L, typename Row>
void count_rows(const L& l, const IndexBox& box, Row&& row) {
  l.sieve->cover(box, [&](const IndexBox& b, std::uint8_t c) {
    if (c != kSieveMaybe) {
      if (L::samples_at(c))
        for (int k = b.lo[2]; k < b.hi[2]; ++k)
          for (int j = b.lo[1]; j < b.hi[1]; ++j)
            row(j, k) += std::uint64_t(b.hi[0] - b.lo[0]);
      return;
    }
    Sample s;
    for (int k = b.lo[2]; k < b.hi[2]; ++k)
      for (int j = b.lo[1]; j < b.hi[1]; ++j)
        for (int i = b.lo[0]; i < b.hi[0]; ++i)
          if (l.make(i, j, k, c, s))
            ++row(j, k);
  });
}

/// Visits the samples of `box` in order: layer k's first id is first_id(k); before row j of it
/// come the samples of its rows below the box (counted by boxes) and of the row's points left of
/// the box, after it those right of it. layer_done(k, n): the box's n samples of layer k.
template <typename L, typename FirstId, typename LayerDone>
std::uint64_t visit(const L& l, const IndexBox& box, FirstId&& first_id, LayerDone&& layer_done,
                    const SampleSink& f) {
  const int nx = l.sieve->size(0);
  const int i0 = box.lo[0], i1 = box.hi[0], j0 = box.lo[1], j1 = box.hi[1], nyr = j1 - j0;
  std::vector<std::uint8_t> cls;
  std::vector<std::uint64_t> below, left, right;
  std::uint64_t points = 0;
  for (int ks = box.lo[2]; ks < box.hi[2]; ks += kSlab) {
    const int ke = std::min(box.hi[2], ks + kSlab), nk = ke - ks;
    below.assign(nk, 0);
    left.assign(std::size_t(nk) * nyr, 0);
    right.assign(std::size_t(nk) * nyr, 0);
    const auto in = [&](std::vector<std::uint64_t>& v) {
      return [&v, ks, j0, nyr](int j, int k) -> std::uint64_t& {
        return v[std::size_t(k - ks) * nyr + (j - j0)];
      };
    };
    count_rows(l, {{0, 0, ks}, {nx, j0, ke}},
               [&](int, int k) -> std::uint64_t& { return below[k - ks]; });
    count_rows(l, {{0, j0, ks}, {i0, j1, ke}}, in(left));
    count_rows(l, {{i1, j0, ks}, {nx, j1, ke}}, in(right));
    const IndexBox mid{{i0, j0, ks}, {i1, j1, ke}};
    l.sieve->classes(mid, cls);
    points += mid.count();
    const std::uint8_t* c = cls.data();
    Sample s;
    for (int k = ks; k < ke; ++k) {
      const std::uint64_t start = first_id(k);
      std::uint64_t id = start + below[k - ks];
      for (int j = j0; j < j1; ++j) {
        id += left[std::size_t(k - ks) * nyr + (j - j0)];
        for (int i = i0; i < i1; ++i, ++c)
          if (l.make(i, j, k, *c, s)) {
            s.id = id++;
            f(s);
          }
        id += right[std::size_t(k - ks) * nyr + (j - j0)];
      }
      layer_done(k, id - start);
    }
  }
  return points;
}

} // namespace

/// The lattices, the solids their classes are bounded by, and what the passes did.
struct SceneSampler::Lattices {
  RigidShapes<double> solids;
  ShapeBounds bounds;
  std::vector<BlockLattice> blocks;
  std::vector<WallLattice> walls; // none or one
  int layers = 0;
  std::uint64_t points = 0, tested = 0;

  explicit Lattices(const Scene& scene) : solids(scene), bounds(solids.table()) {}

  template <typename L>
  void add(std::vector<L>& to, L l) {
    l.first_layer = layers;
    layers += l.sieve->size(2);
    to.push_back(std::move(l));
  }
  template <typename F>
  void each(F&& f) const {
    for (const auto& l : blocks)
      f(l);
    for (const auto& l : walls)
      f(l);
  }
};

SceneSampler::SceneSampler(const Scene& scene, Kind kind, double dp, double depth, bool by_points)
    : l_(std::make_unique<Lattices>(scene)) {
  const auto& shapes = l_->solids.table();
  const ShapeBounds& bounds = l_->bounds;
  const double tol = decided_by(dp);
  if (kind == Kind::Fluid) {
    // Blocks are carved by the solids at t = 0 (a pool around a submerged sphere is one block):
    // a lattice point closer than dp/4 to a solid or inside it is left out. Walls aligned with
    // the lattice keep their first layer (dp/2 from the wall); the boundary shell starts inside
    // the solid.
    const bool carve = scene.has(Module::Boundary);
    const double keep = 0.25 * dp;
    const BoxClassifier classify = [&shapes, &bounds, carve, keep,
                                    tol](const Vec3d& blo, const Vec3d& bhi, double spread) {
      bool free = true;
      for (std::size_t s = 0; carve && s < shapes.size(); ++s) {
        const DistanceBounds d = bounds.over(s, {blo, bhi, spread});
        if (d.upper < keep - tol)
          return kCarved;
        free = free && d.lower >= keep + tol;
      }
      return free ? kFree : kSieveMaybe;
    };
    for (const FluidBlock& b : scene.fluid.blocks) {
      const Vec3d e = b.max - b.min;
      const int n[3] = {cells_along(e.x, dp), cells_along(e.y, dp), cells_along(e.z, dp)};
      const double lo[3] = {b.min.x, b.min.y, b.min.z};
      std::array<std::vector<double>, 3> axes;
      for (int a = 0; a < 3; ++a)
        for (int i = 0; i < n[a]; ++i)
          axes[a].push_back(lo[a] + (i + 0.5) * dp);
      BlockLattice l{nullptr,       0,     &shapes,    carve, keep, dp,
                     b.jitter * dp, b.min, b.velocity, n[0],  n[1], &l_->tested};
      // Each coordinate moves by less than amplitude / 2: a point within sqrt(3) amplitude / 2.
      l.sieve = std::make_unique<LatticeSieve>(std::move(axes),
                                               std::max(0.0, 0.5 * std::sqrt(3.0) * l.amplitude),
                                               by_points ? BoxClassifier{} : classify);
      l_->add(l_->blocks, std::move(l));
    }
    return;
  }
  // The lattice of the fluid (aligned with the domain) continued into every solid, one shell of
  // thickness `depth` deep: at rest a flat wall is then an exact mirror of the fluid, and one
  // rule samples walls, boxes, spheres, planes and meshes (their sampled distance) alike. When the
  // domain is not a multiple of dp the lattice is stretched to fit it (axis_lattice) and each
  // particle's volume scales with it.
  const Vec3d& lo = scene.domain.min;
  const Vec3d& hi = scene.domain.max;
  WallLattice l{nullptr,
                0,
                &shapes,
                axis_lattice(lo.x, hi.x, dp, depth),
                axis_lattice(lo.y, hi.y, dp, depth),
                axis_lattice(lo.z, hi.z, dp, depth),
                scene.obstacles.size(), // index of the walls, if any are closed
                depth,
                dp,
                &l_->tested};
  const BoxClassifier classify = [&shapes, &bounds, depth, tol](const Vec3d& blo, const Vec3d& bhi,
                                                                double spread) {
    for (std::size_t s = 0; s < shapes.size(); ++s) {
      const DistanceBounds d = bounds.over(s, {blo, bhi, spread});
      const bool out = d.lower >= tol || d.upper < -depth - tol;
      if (out)
        continue;
      const bool in = d.lower >= -depth + tol && d.upper < -tol;
      return in && kAllOf + s < kNone ? static_cast<std::uint8_t>(kAllOf + s) : kSieveMaybe;
    }
    return kNone;
  };
  l.sieve =
      std::make_unique<LatticeSieve>(std::array<std::vector<double>, 3>{l.ax.x, l.ay.x, l.az.x},
                                     0.0, by_points ? BoxClassifier{} : classify);
  // The faces the walls' shells lie behind: the first and last interior point of each axis.
  std::array<std::vector<int>, 3> faces;
  const AxisLattice* along[3] = {&l.ax, &l.ay, &l.az};
  const double domain_lo[3] = {lo.x, lo.y, lo.z}, domain_hi[3] = {hi.x, hi.y, hi.z};
  for (int a = 0; a < 3; ++a) {
    const auto& x = along[a]->x;
    faces[a] = {int(std::lower_bound(x.begin(), x.end(), domain_lo[a]) - x.begin()),
                int(std::upper_bound(x.begin(), x.end(), domain_hi[a]) - x.begin())};
  }
  l.sieve->cut_at(std::move(faces));
  l_->add(l_->walls, std::move(l));
}

SceneSampler::~SceneSampler() = default;

int SceneSampler::layers() const {
  return l_->layers;
}

std::vector<std::uint64_t> SceneSampler::layer_samples(int first, int last, std::uint64_t first_id,
                                                       const SampleSink& f) const {
  std::vector<std::uint64_t> counts(std::max(0, last - first), 0);
  std::uint64_t next = first_id;
  l_->each([&](const auto& l) {
    const int k0 = std::max(first - l.first_layer, 0),
              k1 = std::min(last - l.first_layer, l.sieve->size(2));
    const IndexBox rows{{0, 0, k0}, {l.sieve->size(0), l.sieve->size(1), k1}};
    if (rows.empty())
      return; // layers without points: counts 0
    l_->points += visit(
        l, rows, [&](int) { return next; },
        [&](int k, std::uint64_t n) {
          counts[l.first_layer + k - first] = n;
          next += n;
        },
        f);
  });
  return counts;
}

void SceneSampler::samples_in(const Vec3d& lo, const Vec3d& hi, double margin,
                              std::span<const std::uint64_t> layer_counts,
                              const SampleSink& f) const {
  if (layer_counts.size() != std::size_t(l_->layers))
    throw Error("internal: a region's samples asked with " + std::to_string(layer_counts.size()) +
                " layers' counts for " + std::to_string(l_->layers) + " layers");
  std::vector<std::uint64_t> start(layer_counts.size() + 1, 0);
  for (std::size_t k = 0; k < layer_counts.size(); ++k)
    start[k + 1] = start[k] + layer_counts[k];
  const double a[3] = {lo.x, lo.y, lo.z}, b[3] = {hi.x, hi.y, hi.z};
  l_->each([&](const auto& l) {
    const LatticeSieve& sieve = *l.sieve;
    const IndexBox box = sieve.within(sieve.whole(), a, b, margin + sieve.spread());
    if (box.empty())
      return;
    l_->points += visit(
        l, box, [&](int k) { return start[l.first_layer + k]; }, [](int, std::uint64_t) {}, f);
  });
}

SamplerWork SceneSampler::work() const {
  SamplerWork w;
  w.points = l_->points;
  w.tested = l_->tested;
  l_->each([&](const auto& l) { w.boxes += l.sieve->classifications(); });
  return w;
}

} // namespace kf
