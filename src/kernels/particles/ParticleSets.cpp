#include "core/Error.hpp"
#include "kernels/particles/FluidSet.hpp"
#include "kernels/particles/Permute.hpp"

#include <string>

namespace kf {

template <typename T>
FluidSet<T>::FluidSet(exec::Backend b)
    : x(b, 0, "fluid.x"), v(b, 0, "fluid.v"), a(b, 0, "fluid.a"), m(b, 0, "fluid.m"),
      rho(b, 0, "fluid.rho"), p(b, 0, "fluid.p"), drho(b, 0, "fluid.drho"),
      drho_prev(b, 0, "fluid.drho_prev"), id(b, 0, "fluid.id"), xm(b, 0, "fluid.xm"),
      vp(b, 0, "fluid.vp"), vol(b, 0, "fluid.vol"), sorted_(b),
      offsets_(b, 0, "fluid.keep_offsets"), kept_(b, 0, "fluid.kept") {}

template <typename T>
std::size_t FluidSet<T>::keep_flagged(const exec::Exec& ex,
                                      const exec::DeviceBuffer<std::uint32_t>& flags) {
  const std::size_t n = size();
  if (flags.size() != n)
    throw Error("fluid.keep: " + std::to_string(flags.size()) + " flags for " + std::to_string(n) +
                " particles");
  const std::size_t kept = exec::flagged_indices(ex, flags, offsets_, kept_, "fluid.keep");
  if (kept == n)
    return 0;
  reorder(ex, kept_, {true, true});
  return n - kept;
}

template <typename T>
void FluidSet<T>::resize(std::size_t n) {
  x.resize_snug(n);
  v.resize_snug(n);
  a.resize_snug(n);
  m.resize_snug(n);
  rho.resize_snug(n);
  p.resize_snug(n);
  drho.resize_snug(n);
  drho_prev.resize_snug(n);
  id.resize_snug(n);
}

namespace {
/// One sorted particle i of the fluid: every carried field from particle perm[i] of `from` into
/// `to`, and the neighbour copy xm.
template <typename T>
struct GatherFluid {
  const std::uint32_t* perm;
  FluidView<T> from, to;
  bool acceleration, copies;
  KF_HD KF_INLINE void operator()(std::size_t i) const {
    const std::uint32_t j = perm[i];
    const Vec3<T> x = from.x[j];
    const T m = from.m[j];
    to.x[i] = x;
    to.m[i] = m;
    to.xm[i] = {x.x, x.y, x.z, m};
    to.v[i] = from.v[j];
    if (acceleration)
      to.a[i] = from.a[j];
    // rho and its rates are state under the continuity equation; summation recomputes rho (3 x
    // 4 B a particle more per sort, which lists sort seldom).
    to.rho[i] = from.rho[j];
    to.drho[i] = from.drho[j];
    to.drho_prev[i] = from.drho_prev[j];
    to.id[i] = from.id[j];
    if (copies) {
      to.p[i] = from.p[j];
      to.vp[i] = from.vp[j];
      to.vol[i] = from.vol[j];
    }
  }
};
} // namespace

template <typename T>
void FluidSet<T>::reorder(const exec::Exec& ex, const exec::DeviceBuffer<std::uint32_t>& perm,
                          Carry carry) {
  const std::size_t n = perm.size();
  if (n > size())
    throw Error("fluid.reorder: a permutation of " + std::to_string(n) + " for " +
                std::to_string(size()) + " particles");
  const FluidView<T> from = view(); // sizes xm, vp and vol
  each_sorted(*this, carry, [n](auto&, auto& twin) { twin.resize_snug(n); });
  Sorted& s = sorted_;
  FluidView<T> to = from;
  to.x = s.x.data();
  to.v = s.v.data();
  to.a = s.a.data();
  to.m = s.m.data();
  to.rho = s.rho.data();
  to.drho = s.drho.data();
  to.drho_prev = s.drho_prev.data();
  to.id = s.id.data();
  to.p = s.p.data();
  to.vp = s.vp.data();
  to.vol = s.vol.data();
  to.n = n; // xm: written in place (nothing reads it here)
  exec::for_each(ex, n, GatherFluid<T>{perm.data(), from, to, carry.acceleration, carry.copies},
                 "fluid.reorder");
  each_sorted(*this, carry, [](auto& field, auto& twin) { field.swap(twin); });
  if (!carry.acceleration)
    a.resize(n); // a compaction's size; the values wait for the forces pass
  if (!carry.copies)
    p.resize(n); // written by the next density pass
}

template <typename T>
template <typename Self, typename F>
void FluidSet<T>::each_sorted(Self& self, Carry carry, F&& f) {
  auto& s = self.sorted_;
  f(self.x, s.x);
  f(self.v, s.v);
  f(self.m, s.m);
  f(self.rho, s.rho);
  f(self.drho, s.drho);
  f(self.drho_prev, s.drho_prev);
  f(self.id, s.id);
  if (carry.acceleration)
    f(self.a, s.a);
  if (carry.copies) {
    f(self.p, s.p);
    f(self.vp, s.vp);
    f(self.vol, s.vol);
  }
}

template <typename T>
FluidView<T> FluidSet<T>::view() {
  const std::size_t n = size();
  // Each on its own: reorder() swaps vp and vol (carried copies) but not xm. Grown without
  // copying: a growth means particles came (migration, ghosts, a restart's load), and every
  // copy is written again before it is read (reorder carries them only where the count did
  // not change since they were written: one rank's continuity predictor).
  for (auto* b : {&xm, &vp})
    if (b->size() < n)
      b->resize_snug_discarding(n);
  if (vol.size() < n)
    vol.resize_snug_discarding(n);
  return {x.data(),    v.data(),         a.data(), m.data(),  rho.data(), p.data(),  id.data(),
          drho.data(), drho_prev.data(), n,        xm.data(), vp.data(),  vol.data()};
}

template <typename T>
std::size_t FluidSet<T>::bytes_per_particle() {
  // Each twice (reorder's sorted copies): x v a (Vec3), m rho p drho drho_prev vol (T), id, vp
  // (Vec4); grid keys + permutation, the neighbour copy xm.
  return 2 * (3 * sizeof(Vec3<T>) + 6 * sizeof(T) + sizeof(std::uint64_t) + sizeof(Vec4<T>)) +
         2 * sizeof(std::uint32_t) + sizeof(Vec4<T>);
}

template <typename T>
std::size_t FluidSet<T>::bytes() const {
  std::size_t b = xm.capacity_bytes() + offsets_.capacity_bytes() + kept_.capacity_bytes();
  each_sorted(*this, {true, true}, [&](const auto& field, const auto& twin) {
    b += field.capacity_bytes() + twin.capacity_bytes();
  });
  return b;
}

template <typename T>
BoundarySet<T>::BoundarySet(exec::Backend b)
    : x(b, 0, "boundary.x"), x0(b, 0, "boundary.x0"), obstacle(b, 0, "boundary.obstacle"),
      volume(b, 0, "boundary.volume"), p(b, 0, "boundary.p"), id(b, 0, "boundary.id"),
      xv(b, 0, "boundary.xv"), vp(b, 0, "boundary.vp"), inv_rho(b, 0, "boundary.inv_rho"),
      scratch_v3_(b, 0, "boundary.scratch"), scratch_u32_(b, 0, "boundary.scratch"),
      scratch_t_(b, 0, "boundary.scratch"), scratch_id_(b, 0, "boundary.scratch") {}

template <typename T>
void BoundarySet<T>::resize(std::size_t n) {
  x.resize_snug(n);
  x0.resize_snug(n);
  obstacle.resize_snug(n);
  volume.resize_snug(n);
  id.resize_snug(n);
  // Written again before anything reads them (xv by reorder(), which the sort after every
  // resize runs; p, vp and inv_rho by the walls' pass, whose first pass over a build writes every
  // wall): a growth need not copy them. Copied, they were unwritten at a split run's start
  // (compute-sanitizer initcheck); all 86 tests pass with them poisoned at every resize.
  xv.resize_snug_discarding(n);
  vp.resize_snug_discarding(n);
  inv_rho.resize_snug_discarding(n);
  p.resize_snug_discarding(n);
}

namespace {
/// xv[k] = (x_k, V_k).
template <typename T>
struct PackPositionVolume {
  const Vec3<T>* x;
  const T* volume;
  Vec4<T>* xv;
  KF_HD KF_INLINE void operator()(std::size_t k) const {
    const Vec3<T> p = x[k];
    xv[k] = {p.x, p.y, p.z, volume[k]};
  }
};
} // namespace

template <typename T>
void BoundarySet<T>::reorder(const exec::Exec& ex, const exec::DeviceBuffer<std::uint32_t>& perm) {
  permute(ex, perm, x, scratch_v3_, "boundary.reorder");
  permute(ex, perm, x0, scratch_v3_, "boundary.reorder");
  permute(ex, perm, obstacle, scratch_u32_, "boundary.reorder");
  permute(ex, perm, volume, scratch_t_, "boundary.reorder");
  permute(ex, perm, id, scratch_id_, "boundary.reorder");
  exec::for_each(ex, size(), PackPositionVolume<T>{x.data(), volume.data(), xv.data()},
                 "boundary.reorder");
}

template <typename T>
BoundaryView<T> BoundarySet<T>::view() {
  return {x.data(), x0.data(), obstacle.data(), volume.data(), p.data(),
          size(),   xv.data(), vp.data(),       inv_rho.data()};
}

template <typename T>
std::size_t BoundarySet<T>::bytes_per_particle() {
  // x x0 + scratch (Vec3), volume p inv_rho + scratch (T), obstacle + scratch, id + scratch,
  // grid keys + permutation, the forces' gather copies xv and vp (Vec4).
  return 3 * sizeof(Vec3<T>) + 4 * sizeof(T) + 2 * sizeof(std::uint32_t) +
         2 * sizeof(std::uint64_t) + 2 * sizeof(std::uint32_t) + 2 * sizeof(Vec4<T>);
}

template <typename T>
std::size_t BoundarySet<T>::bytes() const {
  std::size_t b = 0;
  for (const auto* v : {&x, &x0, &scratch_v3_})
    b += v->capacity_bytes();
  for (const auto* t : {&volume, &p, &inv_rho, &scratch_t_})
    b += t->capacity_bytes();
  return b + xv.capacity_bytes() + vp.capacity_bytes() + obstacle.capacity_bytes() +
         scratch_u32_.capacity_bytes() + id.capacity_bytes() + scratch_id_.capacity_bytes();
}

template class FluidSet<float>;
template class FluidSet<double>;
template class BoundarySet<float>;
template class BoundarySet<double>;

} // namespace kf
