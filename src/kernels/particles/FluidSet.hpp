#pragma once
#include "core/Vec3.hpp"
#include "kernels/exec/Algorithms.hpp"

#include <cstdint>

namespace kf {

/// Raw pointers into a FluidSet, passed by value into kernels.
template <typename T>
struct FluidView {
  Vec3<T>* x;
  Vec3<T>* v;
  Vec3<T>* a; // acceleration at the current positions (kept: the next half kick needs it)
  T* m;
  T* rho;
  T* p;
  std::uint64_t* id; // global id, never changes
  // drho/dt of this step and of the last (solver.density = "continuity"; else unused): kept
  // across steps like a, since the next step's density predictor extrapolates from both.
  T* drho;
  T* drho_prev;
  std::size_t n;
  // Copies the SPH passes gather from neighbours, packed so that a neighbour costs few loads
  // (the passes were bound by load instructions, docs/PERFORMANCE.md): (x, m) written before
  // the density pass, (v, m P / rho^2) and m / rho written by it for the forces.
  Vec4<T>* xm;
  Vec4<T>* vp;
  T* vol;
};

/// SPH fluid particles, structure of arrays, allocated only when a scene has fluid.
template <typename T>
class FluidSet {
public:
  explicit FluidSet(exec::Backend b);

  std::size_t size() const { return x.size(); }
  void resize(std::size_t n);
  /// What a sort carries besides the state (x, v, m, rho, drho, drho_prev, id).
  struct Carry {
    /// a; without it a is left as it is (stale): for a sort that a forces pass follows before
    /// anything reads a.
    bool acceleration = true;
    /// The step's p, vp and vol: the continuity predictor ran before the sort (they are per
    /// particle functions of the state, so carried they equal a second run of it, to the bit).
    bool copies = false;
  };
  /// Reorders the fluid by a sort permutation (shorter than the set: keeps only the particles
  /// it names, in its order) in one gather pass over all fields, and writes the neighbour copy
  /// xm = (x, m) of the new order (the lists' build reads it). p, vp and vol are left
  /// unwritten unless carried.
  void reorder(const exec::Exec& ex, const exec::DeviceBuffer<std::uint32_t>& perm,
               Carry carry = {});
  FluidView<T> view();
  /// Keeps the particles whose flag is nonzero (flags: one per particle), in their order, with
  /// all fields (rho and p too); returns how many were removed.
  std::size_t keep_flagged(const exec::Exec& ex, const exec::DeviceBuffer<std::uint32_t>& flags);
  /// Bytes each particle may cost, every buffer reorder() can fill included, and the grid's keys
  /// and permutation (`plan`'s estimate).
  static std::size_t bytes_per_particle();
  /// Bytes held now (capacities): a run's second buffers hold only what its sorts carry.
  std::size_t bytes() const;

  exec::DeviceBuffer<Vec3<T>> x, v, a;
  exec::DeviceBuffer<T> m, rho, p, drho, drho_prev;
  exec::DeviceBuffer<std::uint64_t> id;
  // Per-step gather copies (FluidView::xm, vp, vol): recomputed every step; reorder() writes
  // xm and carries vp and vol when asked; view() keeps them as long as the particle count.
  exec::DeviceBuffer<Vec4<T>> xm, vp;
  exec::DeviceBuffer<T> vol;

private:
  // reorder() gathers into these and swaps them in (one pass for every field: seven gathers,
  // one a field, each re-reading the permutation, cost 1.1 s of the column's whole run).
  struct Sorted {
    explicit Sorted(exec::Backend b)
        : x(b, 0, "fluid.sorted"), v(b, 0, "fluid.sorted"), a(b, 0, "fluid.sorted"),
          m(b, 0, "fluid.sorted"), rho(b, 0, "fluid.sorted"), drho(b, 0, "fluid.sorted"),
          drho_prev(b, 0, "fluid.sorted"), p(b, 0, "fluid.sorted"), vol(b, 0, "fluid.sorted"),
          id(b, 0, "fluid.sorted"), vp(b, 0, "fluid.sorted") {}
    exec::DeviceBuffer<Vec3<T>> x, v, a;
    exec::DeviceBuffer<T> m, rho, drho, drho_prev, p, vol;
    exec::DeviceBuffer<std::uint64_t> id;
    exec::DeviceBuffer<Vec4<T>> vp;
  } sorted_;
  /// f(field, its sorted twin) for each field of self (a FluidSet, const or not) that a sort
  /// with `carry` gathers.
  template <typename Self, typename F>
  static void each_sorted(Self& self, Carry carry, F&& f);
  exec::DeviceBuffer<std::uint32_t> offsets_, kept_;
};

/// Raw pointers into a BoundarySet.
template <typename T>
struct BoundaryView {
  Vec3<T>* x;
  const Vec3<T>* x0;             // position at t = 0 (moving obstacles translate it)
  const std::uint32_t* obstacle; // index into the scene's obstacle list; walls use kWallObstacle
  T* volume;                     // volume the particle stands for (psi_b = rho0 volume)
  T* p;                          // pressure extrapolated from the fluid (Adami et al. 2012)
  std::size_t n;
  // The forces pass's gather copies, so that a wall entry costs three loads as a fluid entry
  // does (it took five, one of 12 bytes, and 11% of the pass at the column's start): (x, V),
  // written by reorder(); and (v, P / rho^2), v the no-slip velocity, and 1 / rho, rho the EOS's
  // density of P, written with p by the walls' pass each step.
  const Vec4<T>* xv;
  Vec4<T>* vp;
  T* inv_rho;
};

inline constexpr std::uint32_t kWallObstacle = 0xFFFFFFFFu;

/// Particles filling a shell of each rigid solid (domain walls and obstacles). They add psi = rho0
/// V to the fluid's density and enter the pressure force like fluid particles whose pressure is
/// extrapolated from the fluid next to them (Adami et al. 2012), which holds a column at rest.
template <typename T>
class BoundarySet {
public:
  explicit BoundarySet(exec::Backend b);
  std::size_t size() const { return x.size(); }
  void resize(std::size_t n);
  void reorder(const exec::Exec& ex, const exec::DeviceBuffer<std::uint32_t>& perm);
  BoundaryView<T> view();
  // volume is reordered too: it is per particle so that irregular samplings (meshes) fit.
  static std::size_t bytes_per_particle();
  /// Bytes held now (capacities).
  std::size_t bytes() const;

  exec::DeviceBuffer<Vec3<T>> x, x0;
  exec::DeviceBuffer<std::uint32_t> obstacle;
  exec::DeviceBuffer<T> volume, p;
  exec::DeviceBuffer<std::uint64_t> id;
  // The forces' gather copies (BoundaryView): xv from reorder(); vp, inv_rho and p recomputed
  // every step, not reordered.
  exec::DeviceBuffer<Vec4<T>> xv, vp;
  exec::DeviceBuffer<T> inv_rho;

private:
  exec::DeviceBuffer<Vec3<T>> scratch_v3_;
  exec::DeviceBuffer<std::uint32_t> scratch_u32_;
  exec::DeviceBuffer<T> scratch_t_;
  exec::DeviceBuffer<std::uint64_t> scratch_id_;
};

} // namespace kf
