#pragma once
#include "core/Math.hpp"
// The SPH evaluators: one particle's gather over its neighbours, as host-device functors.
// Gather only (each particle sums what acts on it): no atomics, deterministic sums.
#include "kernels/sph/SphNeighbours_K.hpp"

namespace kf {

/// Particle i's pressure from its density rho, and the forces pass's neighbour copies:
/// (v, m P / rho^2) and m / rho (rho > 0).
template <typename T>
KF_HD KF_INLINE void write_pressure(const FluidView<T>& f, std::size_t i, const Eos<T>& eos, T rho,
                                    T m) {
  const T p = eos.pressure(rho);
  f.p[i] = p;
  const T inv_rho = krcp(rho);
  const Vec3<T> v = f.v[i];
  f.vp[i] = {v.x, v.y, v.z, m * p * inv_rho * inv_rho};
  f.vol[i] = m * inv_rho;
}

/// Continuity: the density a step of dt is predicted to reach, rho + dt (2 drho - drho_prev), the
/// rate extrapolated from the last two steps (docs/PHYSICS.md: with the last rate alone the
/// scheme amplifies sound waves; this one damps them slightly).
template <typename T>
KF_HD KF_INLINE T predicted_density(const FluidView<T>& f, std::size_t i, T dt) {
  return f.rho[i] + dt * (T(2) * f.drho[i] - f.drho_prev[i]);
}

// N: where a particle's neighbours come from (SphNeighbours_K.hpp): SphCellWalk (the grids'
// candidates) or SphList (lists); both meet the neighbours in the same order, so sums agree.
template <typename T, typename K, typename N>
struct DensityEvaluator {
  K kernel;
  Eos<T> eos;
  FluidView<T> f;
  N nb;
  BoundaryNeighbours<T> b;

  KF_HD void operator()(std::size_t i) const {
    const Vec3<T> xi = f.x[i];
    const T h2 = kernel.h * kernel.h;
    T rho = T(0), vol = T(0);
    nb.for_each_neighbour(
        i, xi,
        [&](std::uint32_t j) {
          const Vec4<T> xmj = f.xm[j];
          const T r2 = norm2(xi - xmj.xyz());
          if (r2 < h2)
            rho += xmj.w * kernel.W(ksqrt(r2));
        },
        [&](std::uint32_t k) {
          const T r2 = norm2(xi - b.x[k]);
          if (r2 < h2)
            vol += b.volume[k] * kernel.W(ksqrt(r2));
        });
    rho += eos.rho0 * vol; // psi_b = rho0 V_b
    f.rho[i] = rho;
    write_pressure(f, i, eos, rho, f.m[i]);
  }
};

/// Continuity equation, before the neighbour pass: the pressure of the density predicted over the
/// step and the gather copies (rho itself changes in the forces pass).
template <typename T>
struct DensityPredictor {
  Eos<T> eos;
  FluidView<T> f;
  T dt;

  KF_HD void operator()(std::size_t i) const {
    const Vec3<T> x = f.x[i];
    const T m = f.m[i];
    f.xm[i] = {x.x, x.y, x.z, m};
    write_pressure(f, i, eos, predicted_density(f, i, dt), m);
  }
};

// Listed: the walls' rows of SphLists (fluid within h + s at the last sort, in the walk's
// order, so the sums are the walk's to the bit); a row that overflowed walks the cells.
template <typename T, typename K, bool Listed = false>
struct BoundaryPressureEvaluator {
  K kernel;
  SphParams<T> prm;
  BoundaryView<T> b;
  FluidView<T> f; // reads the gather copies xm and vp (x and v: one 16-byte load each)
  CellView<T> cells;
  const RigidShape<T>* shapes;
  const std::uint8_t* near; // per fluid cell: fluid candidates around it (null: walk every cell)
  ListView<T> walls;        // Listed: row k, boundary particle k's fluid candidates
  bool dry_written = false; // Listed: skip the empty rows (boundary_pressure)

  KF_HD void operator()(std::size_t k) const {
    const Vec3<T> xb = b.x[k]; // before the test: a wet wall's walk waits on no more loads
    if constexpr (Listed)      // its values hold: the pass -8% / -15% at 1M / 8M (H100)
      if (dry_written && walls.count[k] == 0)
        return;
    const T h2 = kernel.h * kernel.h;
    T sum_w = T(0), sum_p = T(0);
    Vec3<T> sum_rho_r{T(0), T(0), T(0)}, sum_v{T(0), T(0), T(0)};
    auto add = [&](std::uint32_t j) {
      const Vec3<T> r = xb - f.xm[j].xyz();
      const T r2 = norm2(r);
      if (r2 >= h2)
        return;
      const T w = kernel.W(ksqrt(r2));
      sum_w += w;
      sum_p += f.p[j] * w;
      sum_rho_r += r * (f.rho[j] * w);
      sum_v += f.vp[j].xyz() * w;
    };
    bool listed = false;
    if constexpr (Listed) {
      listed = walls.complete(k);
      if (listed)
        walls.for_each_neighbour(k, xb, add);
    }
    if (!listed && cells.may_find(near, xb)) // most of a tank's wall particles are dry
      cells.for_each_candidate(xb, add);
    T p = T(0);
    if (sum_w > T(0))
      p = (sum_p + dot(prm.gravity, sum_rho_r)) / sum_w;
    if (p < T(0))
      p = T(0); // a wall never pulls the fluid
    Vec3<T> v{T(0), T(0), T(0)};
    if (prm.no_slip) {
      const std::uint32_t o = b.obstacle[k];
      const Vec3<T> vw = o == kWallObstacle ? Vec3<T>{T(0), T(0), T(0)} : shapes[o].velocity;
      v = sum_w > T(0) ? vw * T(2) - sum_v * (T(1) / sum_w) : vw;
    }
    // The forces pass's copies, with rho the EOS's density of p.
    const T inv_rho = krcp(prm.eos.density(p));
    b.p[k] = p;
    b.vp[k] = {v.x, v.y, v.z, p * inv_rho * inv_rho};
    b.inv_rho[k] = inv_rho;
  }
};

/// What fluid particle i brings to the forces pass's pairs with boundary particles: its velocity,
/// P_i / rho_i^2, 1 / rho_i, 2 mu, the viscous term's eta^2, and whether walls hold the fluid.
template <typename T>
struct WallPairSide {
  Vec3<T> v;
  T p_rho2, inv_rho, mu2, eta2;
  bool no_slip;
};

/// The acceleration of fluid particle i by boundary particle k (a fluid particle of mass
/// psi_k = rho0 V_k and pressure P_k), added to acc in the forces pass's two updates: pressure
/// (Eq. 3) and, no-slip, viscosity (Eq. 4, against the wall's ghost velocity). rik = x_i - x_k,
/// 0 < r2 = |rik|^2 < h^2, dw = dW/dr / r; xvk = (x_k, V_k), vpk = (ghost v_k, P_k / rho_k^2).
/// ForceEvaluator's, and MoverWorkEvaluator's for the moving walls' work.
template <typename T>
KF_HD KF_INLINE void add_wall_pair(Vec3<T>& acc, const WallPairSide<T>& i, const Vec3<T>& rik, T r2,
                                   T dw, T rho0, const Vec4<T>& xvk, const Vec4<T>& vpk,
                                   T inv_rho_k) {
  const T mk = rho0 * xvk.w;
  acc -= rik * (dw * mk * (i.p_rho2 + vpk.w));
  if (i.no_slip)
    acc += (i.v - vpk.xyz()) *
           (mk * i.mu2 * i.inv_rho * inv_rho_k * (r2 * dw) * krcp_fast(r2 + i.eta2));
}

// Continuity: the same pass also sums drho_i/dt (see operator()) and ends the density's step.
// Artificial: Monaghan's artificial viscosity between fluid particles (SphParams::artificial).
template <typename T, typename K, typename N, bool Continuity = false, bool Artificial = false>
struct ForceEvaluator {
  // 1,024 threads (32 warps) an SM in blocks of exec::for_each's size, so at most 64 registers:
  // left to itself ptxas took 66 with the wall entries' three loads (24 warps an SM), and the
  // column's whole run slowed by 8% (H100). Capped, it spills nothing.
  static constexpr unsigned kBlocksPerSm = 1024 / exec::kForEachBlock;
  K kernel;
  SphParams<T> prm;
  FluidView<T> f;
  N nb;
  BoundaryNeighbours<T> b;
  T dt = T(0); // Continuity: the step, rho += dt drho (0: the forces at t = 0, rho kept)

  // On the GPU the lanes of a warp walk their candidates together and ~85% of candidates are
  // out of range, so whenever one lane has a neighbour the whole warp runs the pair code: its
  // cost is paid per candidate. It is written with one reciprocal square root and two
  // reciprocals (no divisions): grad W = r_ij dW/dr / r, and r . grad W = r^2 dW/dr / r.
  //
  // Continuity (DualSPHysics's form, with Fourtakas et al. 2019's diffusion):
  //   drho_i/dt = rho_i sum_j V_j v_ij . grad W_ij
  //             + 2 delta h c0 sum_j V_j (rho_j - rho_i - (rho^H_j - rho^H_i)) (-r^2 dW/dr / r)
  //               / (r^2 + eta^2),
  // V_j = m_j / rho_j, so V_j (rho_j - rho_i) = m_j - V_j rho_i: no division. rho^H is the
  // hydrostatic density, rho^H_j - rho^H_i = -rho0 g . r_ij / c^2 (the EOS linearised at rho0):
  // without it the diffusion would drive a column at rest towards uniform density. The
  // diffusion acts between fluid particles only; walls enter the rate with their own velocity.
  KF_HD void operator()(std::size_t i) const {
    // On the GPU with lists, ~75% of entries are in range, so a warp runs the pair code for
    // nearly every entry anyway: computing it without a branch lets the three gathers of an
    // entry issue together (behind the range test, the compiler sank the second and third into
    // the branch, after the first's latency). Elsewhere, out-of-range candidates return early.
#if defined(__CUDA_ARCH__)
    constexpr bool kBranchFree = N::kListed;
#else
    constexpr bool kBranchFree = false;
#endif
    const Vec3<T> xi = f.x[i];
    const Vec3<T> vi = f.v[i];
    const T h2 = kernel.h * kernel.h;
    const T eta2 = T(0.01) * h2; // keeps the viscous term finite as r -> 0 (Morris et al. 1997)
    const T rho_i = Continuity ? predicted_density(f, i, dt) : f.rho[i];
    const T inv_rho_i = krcp(rho_i);
    const T pi = f.p[i] * inv_rho_i * inv_rho_i;
    const T mu2 = T(2) * prm.viscosity;
    const T visc_i = mu2 * inv_rho_i;
    Vec3<T> acc = prm.gravity;
    // Continuity: sum V_j v_ij . grad W, and the diffusion's sum.
    [[maybe_unused]] T rate = T(0), diffuse = T(0);
    // rho^H_j - rho^H_i = -hydro . r_ij.
    [[maybe_unused]] const Vec3<T> hydro = prm.gravity * (prm.eos.rho0 * krcp(prm.eos.c2));
    // Artificial viscosity: alpha c0 (h / 2), h / 2 the smoothing length, and rho_i.
    [[maybe_unused]] const T av = prm.artificial * T(0.5) * kernel.h;
    // Boundary particles act as fluid particles of mass psi_b = rho0 V_b and pressure P_b. Both
    // sources meet every fluid neighbour before any boundary one, so the sums keep one order.
    const T rho0 = prm.eos.rho0;
    nb.for_each_neighbour(
        i, xi,
        [&](std::uint32_t j) {
          const Vec4<T> xmj = f.xm[j]; // (x_j, m_j)
          const Vec4<T> vpj = f.vp[j]; // (v_j, m_j P_j / rho_j^2)
          const T vol_j = f.vol[j];    // m_j / rho_j
          const Vec3<T> rij = xi - xmj.xyz();
          const T r2 = norm2(rij);
          // r = 0: j == i (or a coincident particle: no direction).
          const bool pair = r2 < h2 && r2 > T(0);
          if constexpr (!kBranchFree) {
            if (!pair)
              return;
          }
          // Branch-free, a lane out of range computes at r = h with dw = 0: every term below
          // is a multiple of dw, so it adds exact zeros.
          const T r2p = pair ? r2 : h2;
          const T inv_r = krsqrt(r2p);
          const T dw = pair ? kernel.dWdr(r2p * inv_r) * inv_r : T(0); // grad W = rij dw
          // Eq. 3: pressure, symmetric in i and j so pair forces cancel.
          const T press = xmj.w * pi + vpj.w;
          // Eq. 4 (Morris form): mu_i + mu_j, relative velocity, (r . grad W) / (r^2 + eta^2),
          // with m_j / rho_j from the density pass.
          const T lap = (r2 * dw) * krcp_fast(r2 + eta2);
          const T vol_lap = vol_j * lap;
          const Vec3<T> vij = vi - vpj.xyz();
          // Two updates, each a fused multiply-add a component (one sum of both terms took a
          // multiply, a multiply-add and an add).
          acc += vij * (visc_i * vol_lap);
          acc -= rij * (dw * press);
          if constexpr (Artificial) {
            // Monaghan (1992), approaching pairs only: a_i -= m_j Pi_ij grad W, Pi_ij =
            // -alpha c0 mu_ij / rho_ij, mu_ij = (h / 2) v_ij . r_ij / (r^2 + eta^2), rho_ij the
            // pair's mean density (rho_j = m_j / V_j). Symmetric in i and j: momentum is kept.
            const T mu = kmin(dot(vij, rij), T(0)) * krcp_fast(r2 + eta2);
            const T pi_ij = -av * mu * T(2) * krcp_fast(rho_i + xmj.w * krcp_fast(vol_j));
            acc -= rij * (dw * xmj.w * pi_ij);
          }
          if constexpr (Continuity) {
            rate += vol_j * dw * dot(vij, rij);
            diffuse += vol_lap * (rho_i - dot(hydro, rij));
            diffuse -= xmj.w * lap;
          }
        },
        [&](std::uint32_t k) {
          const Vec4<T> xvk = b.xv[k]; // (x_k, V_k)
          const Vec3<T> rik = xi - xvk.xyz();
          const T r2 = norm2(rik);
          if (r2 >= h2 || r2 <= T(0))
            return;
          const Vec4<T> vpk = b.vp[k]; // (v_k, P_k / rho_k^2)
          const T inv_r = krsqrt(r2);
          const T dw = kernel.dWdr(r2 * inv_r) * inv_r;
          add_wall_pair(acc, {vi, pi, inv_rho_i, mu2, eta2, b.no_slip}, rik, r2, dw, rho0, xvk, vpk,
                        b.inv_rho[k]);
          if constexpr (Continuity)
            rate += xvk.w * dw * dot(vi - b.wall_velocity(k), rik);
        });
    f.a[i] = acc;
    if constexpr (Continuity) {
      // rho^{n+1} = rho^n + dt drho(x^{n+1}, v^{n+1/2}), like x^{n+1} = x^n + dt v^{n+1/2}; the
      // forces above used the predicted density. dt 0 (t = 0): no history, the rate is its own.
      const T drho = rho_i * rate + T(2) * prm.diffusion * diffuse;
      f.rho[i] = prm.eos.kept_density(f.rho[i] + dt * drho);
      f.drho_prev[i] = dt > T(0) ? f.drho[i] : drho;
      f.drho[i] = drho;
    }
  }
};

/// The work the moving solids' boundary particles do on fluid particle i over a step of dt:
/// dt sum_k F_ik . v_k over its boundary neighbours k of moving obstacles, F_ik the forces pass's
/// pair force on i (add_wall_pair) rebuilt from the copies it read (p, vol, the boundary's xv,
/// vp, inv_rho: valid until the next density pass), v_k the solid's velocity.
/// The rest of the pair's effect, F_ik . (v_i - v_k), is the fluid's own compression and
/// friction against the wall, not work from outside. Rows with owned[i] == 0 (a rank's ghosts)
/// add nothing. The watchdog's energy budget (domain/Watchdog).
template <typename T, typename K>
struct MoverWorkEvaluator {
  K kernel;
  SphParams<T> prm;
  FluidView<T> f;
  BoundaryNeighbours<T> b; // with obstacle and shapes
  const std::uint32_t* owned;
  T dt;

  KF_HD double operator()(std::size_t i) const {
    const Vec3<T> xi = f.x[i];
    if ((owned && !owned[i]) || !b.around(xi))
      return 0.0;
    const T h2 = kernel.h * kernel.h;
    const T mi = f.m[i];
    const T inv_rho_i = f.vol[i] / mi; // the forces pass's 1 / rho_i
    const WallPairSide<T> side{f.v[i],       f.p[i] * inv_rho_i * inv_rho_i,
                               inv_rho_i,    T(2) * prm.viscosity,
                               T(0.01) * h2, b.no_slip};
    double power = 0.0;
    b.cells.for_each_candidate(xi, [&](std::uint32_t k) {
      const std::uint32_t o = b.obstacle[k];
      if (o == kWallObstacle)
        return;
      const Vec3<T> vw = b.shapes[o].velocity;
      if (vw.x == T(0) && vw.y == T(0) && vw.z == T(0))
        return;
      const Vec4<T> xvk = b.xv[k];
      const Vec3<T> rik = xi - xvk.xyz();
      const T r2 = norm2(rik);
      if (r2 >= h2 || r2 <= T(0))
        return;
      const T inv_r = krsqrt(r2);
      const T dw = kernel.dWdr(r2 * inv_r) * inv_r;
      Vec3<T> a{T(0), T(0), T(0)};
      add_wall_pair(a, side, rik, r2, dw, prm.eos.rho0, xvk, b.vp[k], b.inv_rho[k]);
      power += double(dot(a, vw));
    });
    return double(dt) * double(mi) * power;
  }
};

} // namespace kf
