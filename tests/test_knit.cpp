// Knit mass-spring model (paper §3, Fig. 1a): spring forces against their energy, momentum, the
// rest mesh's mass and equilibrium, a hanging strip against the catenary, and a knit-only
// pipeline.
#include "domain/KnitBuilder.hpp"
#include "domain/Simulation.hpp"
#include "kernels/integrate/Verlet.hpp"
#include "kernels/knit/Knit.hpp"
#include "kernels/knit/KnitEvaluators_K.hpp"

#include "support/KnitChecks.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <random>

using namespace kf;

namespace {

/// A random spring network: points in a unit box, each joined to a few random others, with
/// rest lengths off their current lengths (so every spring is loaded), masses and velocities.
struct Network {
  exec::Exec ex{exec::Backend::Cpu};
  KnitSet<double> set{exec::Backend::Cpu};
  SpringTopology<double> springs{exec::Backend::Cpu};
  VolumeTopology<double> volumes{exec::Backend::Cpu};
  std::vector<std::uint32_t> handle_free;
  std::vector<Spring> list;      // the springs built from
  std::vector<VolumeCell> cells; // the cells built from

  explicit Network(std::size_t n, double damping, unsigned seed = 7) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<Vec3d> x(n), v(n);
    std::vector<double> m(n);
    for (std::size_t i = 0; i < n; ++i) {
      x[i] = {u(rng), u(rng), u(rng)};
      v[i] = {u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5};
      m[i] = 0.5 + u(rng);
    }
    for (std::uint32_t i = 0; i < n; ++i)
      for (int k = 0; k < 4; ++k) {
        const auto j = static_cast<std::uint32_t>(rng() % n);
        if (j == i)
          continue;
        Spring s;
        s.i = i;
        s.j = j;
        s.rest = norm(x[j] - x[i]) * (0.7 + 0.6 * u(rng));
        s.k = 10 + 90 * u(rng);
        s.c = damping * u(rng);
        list.push_back(s);
      }
    set.resize(n);
    set.x.assign(x);
    set.v.assign(v);
    set.a.assign(std::vector<Vec3d>(n));
    set.m.assign(m);
    set.handle.assign(std::vector<std::uint32_t>(n, kFreePoint));
    springs.build(list, n);
    // Volume cells on random quadruples, their rest volumes off the current ones (loaded).
    for (std::size_t c = 0; c < n / 2; ++c) {
      VolumeCell cell;
      std::uint32_t q[4];
      for (int r = 0; r < 4; ++r) {
        bool repeated = true;
        while (repeated) {
          q[r] = static_cast<std::uint32_t>(rng() % n);
          repeated = false;
          for (int s2 = 0; s2 < r; ++s2)
            repeated = repeated || q[s2] == q[r];
        }
        cell.point[r] = q[r];
      }
      cell.rest_volume = tet_volume(x[q[0]], x[q[1]], x[q[2]], x[q[3]]) * (0.5 + u(rng));
      cell.k = 1e3 * (0.5 + u(rng));
      cells.push_back(cell);
    }
    volumes.build(cells, n);
  }
};

Scene knit_scene() {
  return test::knit_only_scene("knit");
}

} // namespace

// Springs and volume cells together.
TEST(KnitSprings, ForceIsMinusTheEnergyGradient) {
  Network net(40, 0.0);
  const Vec3d g0{0, 0, 0};
  knit_forces(net.ex, net.set.view(), net.springs.view(), g0, net.volumes.view());
  const auto a = net.set.a.to_host();
  const auto m = net.set.m.to_host();
  auto x = net.set.x.to_host();
  const double eps = 1e-6;
  double worst = 0;
  for (std::size_t i = 0; i < x.size(); i += 3)
    for (int c = 0; c < 3; ++c) {
      auto energy_at = [&](double delta) {
        auto y = x;
        (&y[i].x)[c] += delta;
        net.set.x.assign(y);
        return knit_spring_energy(net.ex, net.set.view(), net.springs.view(), net.volumes.view());
      };
      const double grad = (energy_at(eps) - energy_at(-eps)) / (2 * eps);
      const double force = (&a[i].x)[c] * m[i];
      worst = std::max(worst, std::fabs(force + grad) / (1 + std::fabs(grad)));
    }
  EXPECT_LT(worst, 1e-7) << "F = -dE/dx fails by " << worst;
}

// The per-point tables' two layouts (RowLayout): each maps the n x width (entry, point) pairs
// one to one onto the table's n x width words; the CPU's keeps a point's row in adjacent words
// (its force pass walks one row at a time), the GPU's a slot's points (a warp reads them together).
TEST(KnitSprings, BothRowLayoutsPlaceEveryEntryOnceInTheTable) {
  const std::size_t n = 37;
  const std::uint32_t width = 5;
  for (const exec::Backend b : {exec::Backend::Cpu, exec::Backend::Cuda}) {
    const RowLayout rows = RowLayout::for_backend(b, n, width);
    std::vector<int> seen(n * width, 0);
    for (std::size_t i = 0; i < n; ++i)
      for (std::uint32_t e = 0; e < width; ++e) {
        const std::size_t at = rows.at(e, i);
        ASSERT_LT(at, n * width);
        ++seen[at];
        if (e > 0) {
          EXPECT_EQ(at - rows.at(e - 1, i), b == exec::Backend::Cpu ? std::size_t(1) : n);
        }
      }
    for (int c : seen) {
      ASSERT_EQ(c, 1);
    }
  }
}

// On N ranks (KnitSystem::localize) a rank holds its owned points, then ghosts, in any order:
// the rows localized from the whole network's give every owned point the force it has in the
// whole network, bit for bit (each row in the mesh's order); the ghosts get none (NaN stays).
TEST(KnitSprings, LocalizedRowsGiveTheOwnedPointsTheirWholeNetworkForce) {
  const std::size_t n = 300;
  Network net(n, 0.5);
  const Vec3d g{0, 0, -9.81};
  knit_forces(net.ex, net.set.view(), net.springs.view(), g, net.volumes.view());
  const auto whole = net.set.a.to_host();
  // Owned: a random third; ghosts: every partner of an owned point not owned, plus a few others.
  std::mt19937 rng(11);
  std::vector<std::uint32_t> ids(n);
  std::iota(ids.begin(), ids.end(), 0u);
  std::shuffle(ids.begin(), ids.end(), rng);
  const std::size_t owned = n / 3;
  std::vector<char> is_owned(n, 0), is_ghost(n, 0);
  for (std::size_t k = 0; k < owned; ++k)
    is_owned[ids[k]] = 1;
  const auto partner = [&](std::uint32_t a, std::uint32_t b) {
    if (is_owned[a] && !is_owned[b])
      is_ghost[b] = 1;
  };
  for (const Spring& sp : net.list)
    partner(sp.i, sp.j), partner(sp.j, sp.i);
  for (const VolumeCell& c : net.cells)
    for (auto a : c.point)
      for (auto b : c.point)
        partner(a, b);
  for (std::size_t k = owned; k < owned + 10; ++k)
    is_ghost[ids[k]] = is_owned[ids[k]] ? 0 : 1;
  std::vector<std::uint64_t> local_ids(ids.begin(), ids.begin() + owned);
  for (std::size_t k = n; k-- > 0;) // ghosts in another order than the owned ones
    if (is_ghost[k])
      local_ids.push_back(k);
  const std::size_t m = local_ids.size();
  ASSERT_LT(m, n) << "every point is here: a weak case";
  std::vector<std::uint32_t> local_of_id(n, 0xFFFFFFFFu);
  for (std::size_t k = 0; k < m; ++k)
    local_of_id[local_ids[k]] = static_cast<std::uint32_t>(k);
  // The local points' state, by id.
  const auto x = net.set.x.to_host(), v = net.set.v.to_host();
  const auto mass = net.set.m.to_host();
  std::vector<Vec3d> lx(m), lv(m);
  std::vector<double> lm(m);
  for (std::size_t k = 0; k < m; ++k)
    lx[k] = x[local_ids[k]], lv[k] = v[local_ids[k]], lm[k] = mass[local_ids[k]];
  KnitSet<double> local(exec::Backend::Cpu);
  local.resize(m);
  local.x.assign(lx);
  local.v.assign(lv);
  local.m.assign(lm);
  local.handle.assign(std::vector<std::uint32_t>(m, kFreePoint));
  local.id.assign(local_ids);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  local.a.assign(std::vector<Vec3d>(m, Vec3d{nan, nan, nan}));
  exec::DeviceBuffer<std::uint32_t> lof(exec::Backend::Cpu, 0, "test.local_of_id");
  lof.assign(local_of_id);
  SpringTopology<double> springs{exec::Backend::Cpu};
  VolumeTopology<double> volumes{exec::Backend::Cpu};
  // The rows as N ranks keep them: on the host, row-major, the springs' and the cells' for the
  // rank's points in its order (lists holding more than theirs: the others are passed over), the
  // cells' corners and constants for the whole mesh.
  const std::vector<std::uint64_t> mine(local_ids.begin(), local_ids.begin() + owned);
  std::vector<std::uint32_t> cell_index(net.cells.size());
  std::iota(cell_index.begin(), cell_index.end(), 0u);
  const auto rank_springs =
      SpringTopology<double>::host_rows(exec::Backend::Cpu, net.list, n, mine);
  const auto rank_cells =
      VolumeTopology<double>::host_rows(exec::Backend::Cpu, net.cells, cell_index, n, mine);
  const auto mesh_cells = VolumeTopology<double>::mesh_cells(exec::Backend::Cpu, net.cells, n);
  springs.localize(net.ex, rank_springs, lof.data(), owned);
  volumes.localize(net.ex, mesh_cells, rank_cells, lof.data(), owned);
  { // The step limits N ranks take (the minimum over the ranks of their owned points'): each
    // owned point's from the localized rows is its value on one rank, to the bit.
    auto lv = local.view();
    const SpringLimitEvaluator<double> here{lv, springs.view(), volumes.view()},
        whole_net{net.set.view(), net.springs.view(), net.volumes.view()};
    std::size_t limited = 0;
    for (std::size_t k = 0; k < owned; ++k) {
      const auto a = here(k), b = whole_net(local_ids[k]);
      ASSERT_TRUE(a.spring == b.spring && a.damping == b.damping) << "point " << local_ids[k];
      limited += b.spring < 1e29;
    }
    EXPECT_GT(limited, 0u) << "no spring limited the step: a weak case";
  }
  auto view = local.view();
  view.n = owned;
  knit_forces(net.ex, view, springs.view(), g, volumes.view());
  const auto a = local.a.to_host();
  for (std::size_t k = 0; k < owned; ++k) {
    const Vec3d& w = whole[local_ids[k]];
    ASSERT_TRUE(a[k].x == w.x && a[k].y == w.y && a[k].z == w.z)
        << "owned point " << local_ids[k] << ": " << a[k].x << " against " << w.x;
  }
  for (std::size_t k = owned; k < m; ++k)
    ASSERT_TRUE(std::isnan(a[k].x)) << "a ghost's force was written";
  // Rows for the owned points only (the ghosts' are their owners'); each its mesh point's.
  EXPECT_EQ(springs.points(), owned);
  EXPECT_EQ(volumes.points(), owned);
  const auto count = springs.view(), mesh_count = net.springs.view();
  for (std::size_t k = 0; k < owned; ++k)
    EXPECT_EQ(count.count[k], mesh_count.count[local_ids[k]]);
  // The halo's check from those rows (knit_partner_reach) against a walk of the lists: the
  // farthest partner of an owned point, to the bit (the same squared sums), none absent.
  double want = 0;
  const auto meet = [&](std::uint32_t a, std::uint32_t b) {
    if (local_of_id[a] < owned)
      want = std::max(want, norm2(x[b] - x[a]));
  };
  for (const Spring& sp : net.list)
    meet(sp.i, sp.j), meet(sp.j, sp.i);
  for (const VolumeCell& c : net.cells)
    for (auto a : c.point)
      for (auto b : c.point)
        if (a != b)
          meet(a, b);
  const auto reach =
      knit_partner_reach(net.ex, owned, local.x.data(), springs.view(), volumes.view());
  EXPECT_EQ(reach.missing, 0u);
  EXPECT_EQ(reach.d2, want);
  EXPECT_GT(want, 0.0) << "no partner met: a weak case";
  // A ghost at a spring's end from an owned point left out: the check finds it absent.
  std::uint32_t gone = kAbsentPoint;
  for (const Spring& sp : net.list)
    for (auto [a, b] : {std::pair{sp.i, sp.j}, std::pair{sp.j, sp.i}})
      if (local_of_id[a] < owned && local_of_id[b] >= owned && local_of_id[b] != kAbsentPoint)
        gone = b;
  ASSERT_NE(gone, kAbsentPoint) << "no spring crosses to a ghost: a weak case";
  local_of_id[gone] = kAbsentPoint;
  lof.assign(local_of_id);
  springs.localize(net.ex, rank_springs, lof.data(), owned);
  volumes.localize(net.ex, mesh_cells, rank_cells, lof.data(), owned);
  EXPECT_EQ(
      knit_partner_reach(net.ex, owned, local.x.data(), springs.view(), volumes.view()).missing,
      1u);
}

TEST(KnitSprings, PairForcesCancelAndAFreeSystemKeepsItsMomentum) {
  Network net(60, 2.0); // damped springs too: damping is along the spring, equal and opposite
  const Vec3d g0{0, 0, 0};
  auto momentum = [&] {
    const auto v = net.set.v.to_host();
    const auto m = net.set.m.to_host();
    Vec3d p{0, 0, 0};
    for (std::size_t i = 0; i < v.size(); ++i)
      p += v[i] * m[i];
    return p;
  };
  knit_forces(net.ex, net.set.view(), net.springs.view(), g0, net.volumes.view());
  {
    const auto a = net.set.a.to_host();
    const auto m = net.set.m.to_host();
    Vec3d f{0, 0, 0};
    double scale = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      f += a[i] * m[i];
      scale += norm(a[i]) * m[i];
    }
    EXPECT_LT(norm(f), 1e-12 * scale) << "net internal force " << norm(f) << " of " << scale;
  }
  const Vec3d p0 = momentum();
  std::vector<Vec3d> hv(1);
  exec::DeviceBuffer<Vec3d> handles(exec::Backend::Cpu);
  handles.assign(hv);
  for (int s = 0; s < 2000; ++s) {
    auto p = net.set.view();
    const Prescribed<double> fixed{p.handle, handles.data()};
    kick_drift(net.ex, p.x, p.v, p.a, p.n, 1e-4, 1.0, "test.kick_drift", fixed);
    knit_forces(net.ex, p, net.springs.view(), g0, net.volumes.view());
    kick(net.ex, p.v, p.a, p.n, 1e-4, 1.0, "test.kick", fixed);
  }
  const Vec3d p1 = momentum();
  EXPECT_LT(norm(p1 - p0), 1e-12 * (1 + norm(p0))) << "momentum drifted by " << norm(p1 - p0);
}

TEST(KnitMesh, PatchHasTheFabricsMassAndIsAtRestWhenUndeformed) {
  Scene s = knit_scene();
  KnitPiece p;
  p.center = {0, 0, 0};
  p.width = 0.3;
  p.height = 0.2;
  p.wales = 15;
  p.courses = 10;
  s.knit.pieces = {p};
  const KnitMesh mesh = build_knit(s);
  ASSERT_EQ(mesh.x.size(), 3u * 16 * 11);
  double mass = 0;
  for (double m : mesh.m)
    mass += m;
  EXPECT_NEAR(mass, s.knit.mass_per_area * 0.3 * 0.2, 1e-12);
  // Layers at +t/2, 0, -t/2 along the normal.
  EXPECT_NEAR(mesh.x[0].z, 0.5 * s.knit.thickness, 1e-15);
  EXPECT_NEAR(mesh.x[2 * 16 * 11].z, -0.5 * s.knit.thickness, 1e-15);
  // Undeformed: every spring at its rest length, so free points feel gravity alone.
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  const io::Frame fr = sim->frame();
  const auto a = fr.find("knit")->find("acceleration")->as<double>();
  for (std::size_t i = 0; i < a.size(); i += 3) {
    ASSERT_NEAR(a[i], s.gravity.x, 1e-9);
    ASSERT_NEAR(a[i + 2], s.gravity.z, 1e-9);
  }
}

TEST(KnitMesh, TubeClosesOnItself) {
  Scene s = knit_scene();
  KnitPiece p;
  p.shape = KnitShape::Tube;
  p.center = {0, 0, 0};
  p.normal = {0, 0, 1};
  p.circumference = 0.25;
  p.length = 0.3;
  p.wales = 24;
  p.courses = 12;
  s.knit.pieces = {p};
  const KnitMesh mesh = build_knit(s);
  ASSERT_EQ(mesh.x.size(), 3u * 24 * 13);
  // The middle layer's circumference (a closed polygon of 24 sides) is the tube's.
  const auto& L = mesh.pieces[0];
  double c = 0;
  for (int i = 0; i < 24; ++i)
    c += norm(mesh.x[L.index(1, (i + 1) % 24, 0)] - mesh.x[L.index(1, i, 0)]);
  EXPECT_NEAR(c, 0.25, 0.25 * 0.003); // polygon vs circle: 1 - sin(pi/24)/(pi/24) = 0.29%
  // Every point has the same number of in-layer stretch neighbours (no seam).
  std::vector<int> stretch(mesh.x.size(), 0);
  for (const auto& sp : mesh.springs)
    if (sp.kind == SpringKind::Stretch)
      ++stretch[sp.i], ++stretch[sp.j];
  EXPECT_EQ(stretch[L.index(1, 0, 5)], 4);
  EXPECT_EQ(stretch[L.index(1, 23, 5)], 4);
}

// A strip hung from both ends sags into a catenary y = a cosh(x / a). The strip starts straight
// and horizontal, its ends are walked inward to the span, and global damping settles it. The
// reference catenary has the settled strip's span and arc length (which include its stretch).
TEST(KnitMesh, HangingStripSettlesToTheCatenary) {
  Scene s = knit_scene();
  const double L = 1.0, span = 0.6, width = 0.01;
  KnitPiece p;
  p.center = {0, 0, 0};
  p.normal = {0, 0, 1}; // a horizontal strip (width along y): it bends through its thickness
  p.u_axis = {1, 0, 0};
  p.width = L;
  p.height = width;
  p.wales = 60;
  p.courses = 1;
  s.knit.pieces = {p};
  s.knit.thickness = 4e-4; // thin: bending (from the layers' separation) stays negligible
  s.knit.mass_per_area = 2.0;
  s.knit.stretch = 2000;
  s.knit.compression = 200;
  s.knit.layer_shear = 100;
  s.knit.bend = 0;
  const double walk = 0.5 * (L - span), v = 0.5;
  KnitPin left, right;
  left.min = {-0.5 * L - 1e-6, -1, -1};
  left.max = {-0.5 * L + 1e-6, 1, 1};
  left.velocity = {v, 0, 0};
  left.move_until = walk / v;
  right.min = {0.5 * L - 1e-6, -1, -1};
  right.max = {0.5 * L + 1e-6, 1, 1};
  right.velocity = {-v, 0, 0};
  right.move_until = walk / v;
  s.knit.pins = {left, right};
  s.solver.damping = 8;
  s.solver.damping_until = 1e9;
  s.end_time = 4.0;
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  while (sim->time() < s.end_time)
    sim->step(s.end_time);

  const io::Frame fr = sim->frame();
  const auto x = fr.find("knit")->find("position")->as<double>();
  const KnitPieceLayout lay = build_knit(s).pieces[0];
  // The middle layer's centre line: the average of its two rows.
  std::vector<Vec3d> c(lay.nu);
  for (int i = 0; i < lay.nu; ++i) {
    Vec3d sum{0, 0, 0};
    for (int j = 0; j < lay.nv; ++j) {
      const std::size_t k = lay.index(1, i, j);
      sum += Vec3d{x[3 * k], x[3 * k + 1], x[3 * k + 2]};
    }
    c[i] = sum * (1.0 / lay.nv);
  }
  double arc = 0;
  for (int i = 0; i + 1 < lay.nu; ++i)
    arc += norm(c[i + 1] - c[i]);
  const double S = c.back().x - c.front().x, xm = 0.5 * (c.back().x + c.front().x);
  ASSERT_NEAR(S, span, 1e-3); // a handle stops at the end of the substep it passes move_until in
  // Solve arc = 2 a sinh(S / 2a) for a by bisection (the left side falls as a grows).
  double lo = 1e-3, hi = 100;
  for (int it = 0; it < 200; ++it) {
    const double a = 0.5 * (lo + hi);
    (2 * a * std::sinh(S / (2 * a)) > arc ? lo : hi) = a;
  }
  const double a = 0.5 * (lo + hi), z_end = c.front().z;
  double worst = 0;
  for (const Vec3d& q : c) {
    const double z = z_end + a * (std::cosh((q.x - xm) / a) - std::cosh(S / (2 * a)));
    worst = std::max(worst, std::fabs(q.z - z));
  }
  const double sag = z_end - c[lay.nu / 2].z;
  std::printf("span %.3f m, arc %.4f m (rest %.3f), catenary a = %.4f m, sag %.4f m, worst "
              "deviation %.2e m = %.2f%% of the span\n",
              S, arc, L, a, sag, worst, 100 * worst / S);
  EXPECT_GT(sag, 0.3) << "the strip did not hang";
  EXPECT_LT(worst, 0.02 * S);
  const Diagnostics d = sim->diagnostics();
  EXPECT_LT(d.knit_kinetic_energy, 1e-6 * std::fabs(d.knit_potential_energy)) << "not settled";
}

TEST(KnitPipeline, AKnitOnlySceneHasNoFluidStageAndNoFluidArrays) {
  Scene s = knit_scene();
  KnitPiece p;
  p.center = {0, 0, 0};
  s.knit.pieces = {p};
  auto sim = Simulation::create(s, exec::Backend::Cpu);
  for (const auto& st : sim->pipeline().stages())
    EXPECT_EQ(st.module, "knit") << st.name;
  EXPECT_FALSE(sim->pipeline().has_module("fluid"));
  EXPECT_FALSE(sim->pipeline().has_module("boundary"));
  const io::Frame fr = sim->frame();
  // The knit's mass points and its yarn polylines (yarn_samples > 0 by default); nothing else.
  ASSERT_EQ(fr.phases.size(), 2u);
  EXPECT_EQ(fr.phases[0].name, "knit");
  EXPECT_EQ(fr.phases[1].name, "yarn");
  const Diagnostics d = sim->diagnostics();
  EXPECT_EQ(d.fluid, 0u);
  EXPECT_EQ(d.boundary, 0u);
  EXPECT_EQ(d.knit, 3u * 21 * 21);
  // Memory is the knit's alone: its points and springs.
  const PlanReport r = Simulation::plan(s);
  EXPECT_EQ(r.fluid, 0u);
  EXPECT_EQ(r.bytes_fluid + r.bytes_boundary + r.bytes_grid, 0u);
  EXPECT_EQ(r.knit, d.knit);
  EXPECT_GE(sim->memory_bytes(), r.bytes_knit);
  EXPECT_LE(sim->memory_bytes(), r.bytes_knit + 1024) << "beyond the knit and the solids' table";
}
