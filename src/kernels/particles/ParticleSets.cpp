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
      vp(b, 0, "fluid.vp"), vol(b, 0, "fluid.vol"), scratch_v3_(b, 0, "fluid.scratch"),
      scratch_t_(b, 0, "fluid.scratch"), scratch_id_(b, 0, "fluid.scratch"),
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
  reorder(ex, kept_);
  permute(ex, kept_, p, scratch_t_, "fluid.keep");
  return n - kept;
}

template <typename T>
void FluidSet<T>::resize(std::size_t n) {
  x.resize(n);
  v.resize(n);
  a.resize(n);
  m.resize(n);
  rho.resize(n);
  p.resize(n);
  drho.resize(n);
  drho_prev.resize(n);
  id.resize(n);
}

template <typename T>
void FluidSet<T>::reorder(const exec::Exec& ex, const exec::DeviceBuffer<std::uint32_t>& perm,
                          bool acceleration) {
  permute(ex, perm, x, scratch_v3_, "fluid.reorder");
  permute(ex, perm, v, scratch_v3_, "fluid.reorder");
  if (acceleration)
    permute(ex, perm, a, scratch_v3_, "fluid.reorder");
  else
    a.resize(perm.size()); // a compaction's size; the values wait for the forces pass
  permute(ex, perm, m, scratch_t_, "fluid.reorder");
  // rho and its rates are state under the continuity equation; summation recomputes rho (3 x 4 B
  // a particle more per sort, which lists sort seldom).
  permute(ex, perm, rho, scratch_t_, "fluid.reorder");
  permute(ex, perm, drho, scratch_t_, "fluid.reorder");
  permute(ex, perm, drho_prev, scratch_t_, "fluid.reorder");
  permute(ex, perm, id, scratch_id_, "fluid.reorder");
}

template <typename T>
FluidView<T> FluidSet<T>::view() {
  const std::size_t n = size();
  if (xm.size() < n) {
    xm.resize(n);
    vp.resize(n);
    vol.resize(n);
  }
  return {x.data(),    v.data(),         a.data(), m.data(),  rho.data(), p.data(),  id.data(),
          drho.data(), drho_prev.data(), n,        xm.data(), vp.data(),  vol.data()};
}

template <typename T>
std::size_t FluidSet<T>::bytes_per_particle() {
  // x v a + scratch (Vec3), m rho p drho drho_prev + scratch (T), id + scratch, grid keys +
  // permutation, the SPH gather copies (xm, vp, vol).
  return 4 * sizeof(Vec3<T>) + 6 * sizeof(T) + 2 * sizeof(std::uint64_t) +
         2 * sizeof(std::uint32_t) + 2 * sizeof(Vec4<T>) + sizeof(T);
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
  x.resize(n);
  x0.resize(n);
  obstacle.resize(n);
  volume.resize(n);
  p.resize(n);
  id.resize(n);
  xv.resize(n);
  vp.resize(n);
  inv_rho.resize(n);
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

template class FluidSet<float>;
template class FluidSet<double>;
template class BoundarySet<float>;
template class BoundarySet<double>;

} // namespace kf
