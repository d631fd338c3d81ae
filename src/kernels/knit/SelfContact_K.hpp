#pragma once
// Knit self-collision (paper §3 and §5.1, Eq. 7 and 8 as corrected in DESIGN §10): DEM penalty
// forces between knit points of radius R that overlap and are not close on the rest mesh.
// Gather form: each point sums the forces its neighbours exert on it (no atomics; the pair force
// is antisymmetric, so momentum is conserved to rounding).
#include "core/Math.hpp"
#include "kernels/contact/DemContact_K.hpp"
#include "kernels/exec/Algorithms.hpp"
#include "kernels/grid/GridGeometry.hpp"
#include "kernels/grid/NeighbourList.hpp"
#include "kernels/particles/KnitSet.hpp"

#include <cstdint>

namespace kf {

template <typename T>
struct SelfContactParams {
  T radius = T(0);     // R: two points touch at |r| = 2R
  T exclusion2 = T(0); // squared rest distance below which points of one piece never collide
  T k = T(0);          // normal stiffness [N/m]
  T zeta = T(0);       // normal damping ratio (of critical, per pair)
  T friction = T(0);   // Coulomb coefficient mu
};

/// The knit points in grid (cell) order: copies gathered through the grid's permutation, so the
/// candidate loop reads contiguous memory; the knit set itself keeps its rest-mesh order.
template <typename T>
struct SortedKnitView {
  const Vec3<T>* x;
  const Vec3<T>* v;
  const Vec3<T>* rest;
  const T* m;
  const std::uint16_t* piece;
};

/// Force on i from j (d = x_i - x_j, dv = v_i - v_j): the DEM pair force with reach 2R.
template <typename T>
KF_HD KF_INLINE bool self_contact_force(const Vec3<T>& d, const Vec3<T>& dv, T mi, T mj,
                                        const SelfContactParams<T>& p, Vec3<T>& f) {
  return dem_pair_force(d, dv, mi, mj, T(2) * p.radius, DemMaterial<T>{p.k, p.zeta, p.friction}, f);
}

/// True when i and j may collide: different pieces, or far enough apart on the rest mesh (springs
/// and the rest thickness keep close points apart; a contact there would fight the springs).
template <typename T>
KF_HD KF_INLINE bool self_contact_allowed(std::uint16_t piece_i, std::uint16_t piece_j,
                                          const Vec3<T>& rest_i, const Vec3<T>& rest_j,
                                          T exclusion2) {
  return piece_i != piece_j || norm2(rest_i - rest_j) >= exclusion2;
}

/// a_i += (sum of self-contact forces on i) / m_i for every free point, over the partners listed
/// at the grid's sort (or its cells where its list overflowed). When the watched motion since
/// the sort passed its skin (*moved2 > skin2: a list may miss a partner) but not the cells'
/// margin (walk2 = (cell - 2R)^2: a partner within 2R of i now was within a cell edge of i's
/// position now where the grid sorted it), i walks its 27 cells; past the margin every point
/// sums over all n points instead: exact, O(n^2), and rare (KnitSelfContact::begin_step sorts
/// ahead of the motion it expects, which a splash can outrun).
template <typename T>
struct SelfContactEvaluator {
  KnitView<T> p;
  const Vec3<T>* rest;
  const std::uint16_t* piece;
  SortedKnitView<T> s;
  CellView<T> cells;
  SelfContactParams<T> params;
  ListView<T> list; // per point: the allowed partners within a cell edge at the sort
  const T* moved2;
  T skin2;
  T walk2; // (cell - 2R)^2: the grid's cells hold up to this motion
  std::uint32_t n;

  KF_HD void operator()(std::size_t i, exec::Lanes g = {}) const {
    if (p.handle[i] != kFreePoint)
      return;
    const Vec3<T> f = force(i, g);
    if (g.lane == 0)
      p.a[i] += f * (T(1) / p.m[i]);
  }

  /// The self-contact force on free point i, summed over the group's lanes (KnitPointForces).
  KF_HD KF_INLINE Vec3<T> force(std::size_t i, exec::Lanes g) const {
    const Vec3<T> xi = p.x[i], vi = p.v[i], ri = rest[i];
    const T mi = p.m[i];
    const std::uint16_t pi = piece[i];
    Vec3<T> f{T(0), T(0), T(0)};
    const T reach2 = T(4) * params.radius * params.radius;
    auto pair = [&](std::uint32_t j) {
      const Vec3<T> d = xi - s.x[j];
      // Distance first: most candidates are out of reach, and it reads one array, not three.
      if (norm2(d) >= reach2 ||
          !self_contact_allowed(pi, s.piece[j], ri, s.rest[j], params.exclusion2))
        return;
      Vec3<T> fij;
      if (self_contact_force(d, vi - s.v[j], mi, s.m[j], params, fij))
        f += fij;
    };
    const T m2 = *moved2; // NaN: all pairs
    if (m2 <= skin2 && list.count && list.complete(i))
      list.for_each_neighbour(i, xi, g.lane, g.size, pair);
    else if (m2 <= walk2)
      cells.for_each_candidate(xi, g.lane, g.size, pair);
    else
      for (std::uint32_t j = g.lane; j < n; j += g.size)
        pair(j);
    return g.sum(f);
  }
};

/// Whether sorted point j may ever touch point i (list building: the exclusion depends only on
/// pieces and rest positions, so it holds for the list's whole life).
template <typename T>
struct SelfPairAllowed {
  const std::uint16_t* piece; // knit order
  const Vec3<T>* rest;        // knit order
  SortedKnitView<T> s;
  T exclusion2;
  KF_HD KF_INLINE bool operator()(std::size_t i, std::uint32_t j) const {
    return self_contact_allowed(piece[i], s.piece[j], rest[i], s.rest[j], exclusion2);
  }
};

/// Per-point contact diagnostics: contacts counted once per pair, the penalty energy
/// 1/2 k u^2 (half per side) and the smallest centre distance over 2R.
struct SelfContactStats {
  std::uint64_t contacts = 0;
  double energy = 0;
  double min_gap_ratio = 1e30;
};

struct SelfContactStatsOp {
  KF_HD KF_INLINE SelfContactStats operator()(const SelfContactStats& a,
                                              const SelfContactStats& b) const {
    return {a.contacts + b.contacts, a.energy + b.energy,
            a.min_gap_ratio < b.min_gap_ratio ? a.min_gap_ratio : b.min_gap_ratio};
  }
};

template <typename T>
struct SelfContactStatsEvaluator {
  const Vec3<T>* x;
  const Vec3<T>* rest;
  const std::uint16_t* piece;
  const std::uint64_t* id;
  SortedKnitView<T> s;
  const std::uint64_t* sorted_id;
  CellView<T> cells;
  SelfContactParams<T> params;

  KF_HD SelfContactStats operator()(std::size_t i) const {
    SelfContactStats st;
    const Vec3<T> xi = x[i], ri = rest[i];
    const T reach = T(2) * params.radius;
    cells.for_each_candidate(xi, [&](std::uint32_t j) {
      if (!self_contact_allowed(piece[i], s.piece[j], ri, s.rest[j], params.exclusion2))
        return;
      const T r = norm(xi - s.x[j]);
      if (r >= reach)
        return;
      const double u = double(reach - r);
      st.energy += 0.25 * double(params.k) * u * u;
      if (id[i] < sorted_id[j])
        ++st.contacts;
      const double ratio = double(r / reach);
      if (ratio < st.min_gap_ratio)
        st.min_gap_ratio = ratio;
    });
    return st;
  }
};

} // namespace kf
