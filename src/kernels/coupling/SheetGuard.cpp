#include "kernels/coupling/SheetGuard.hpp"

#include "core/Error.hpp"

#include <cmath>
#include <string>

namespace kf {

template <typename T>
SheetGuard<T>::SheetGuard(exec::Backend b, const std::vector<std::array<std::uint32_t, 3>>& faces,
                          const std::vector<std::uint32_t>& offsets,
                          const std::vector<std::uint32_t>& ids, T gap, T speed_scale)
    : vertex_(b, 0, "sheet_guard.vertex"), offsets_(b, 0, "sheet_guard.offsets"),
      ids_(b, 0, "sheet_guard.faces"), extent_(b, kSheetExtentValues, "sheet_guard.extent"),
      hit_face_(b, 0, "sheet_guard.hit_face"), hit_w_(b, 0, "sheet_guard.hit_w"),
      hit_n_(b, 0, "sheet_guard.hit_n"), sums_(b, 0, "sheet_guard.sums"), gap_(gap),
      quantum_(static_cast<T>(std::ldexp(double(speed_scale), -40))) {
  if (!(speed_scale > T(0)) || !std::isfinite(double(speed_scale)))
    throw Error("sheet guard: the fluid's speed scale is " + std::to_string(speed_scale) +
                ", expected a positive finite speed");
  if (offsets.empty() || offsets.back() != ids.size() || ids.size() != 3 * faces.size())
    throw Error("sheet guard: " + std::to_string(ids.size()) + " face entries for " +
                std::to_string(faces.size()) + " faces (3 each)");
  std::vector<std::uint32_t> v;
  v.reserve(3 * faces.size());
  for (const auto& f : faces)
    v.insert(v.end(), f.begin(), f.end());
  vertex_.assign(v);
  offsets_.assign(offsets);
  ids_.assign(ids);
}

template <typename T>
void SheetGuard<T>::apply(const exec::Exec& ex, FluidView<T> f, T dt, KnitSet<T>& knit,
                          const exec::DeviceBuffer<Vec3<T>>& knit_x0,
                          const KnitFluidCoupling<T>& coupling, const std::uint32_t* knit_of_id,
                          const std::uint32_t* counted, std::uint64_t* count,
                          const GhostSums& ghost_sums) const {
  if (knit_x0.size() != knit.size())
    throw Error("sheet guard: " + std::to_string(knit_x0.size()) +
                " knit positions at the step's start for " + std::to_string(knit.size()) +
                " points");
  // On N ranks a rank without fluid or knit still takes part in the sums' exchanges.
  const bool meets = knit.size() > 0 && f.n > 0;
  if (!meets && !ghost_sums)
    return;
  sums_.resize(kSheetSumWidth * knit.size());
  exec::fill(ex, sums_, std::uint64_t(0), "coupling.sheet_guard");
  const SheetFacesView sheet{vertex_.data(), offsets_.data(), ids_.data(), knit_of_id};
  hit_face_.resize(f.n);
  hit_w_.resize(f.n);
  hit_n_.resize(f.n);
  const SheetHits<T> hits{hit_face_.data(), hit_w_.data(), hit_n_.data()};
  if (meets) {
    const GridGeometry<T> geo = coupling.knit_grid().geometry();
    exec::fill(ex, extent_, T(0), "coupling.sheet_guard");
    exec::max_into_each<T, kSheetExtentValues>(
        ex, faces(), SheetExtent<T>{knit.x.data(), knit_x0.data(), sheet, geo}, extent_.data(),
        "coupling.sheet_guard");
    // The coupling grid's points moved at most three of its watch's skins since its sort (one
    // before the step, two in it: KnitFluidCoupling::begin_step); the near flags were taken up
    // to flag_slack() from where the particles' steps began (lists kept for an anchor): a
    // particle may be that much nearer, and the walk reaches that much farther.
    exec::transform_reduce_into(
        ex, f.n, exec::SumOp{},
        SheetGuardEvaluator<T>{f.x, f.v, counted, knit.x.data(), knit_x0.data(), knit.id.data(),
                               coupling.knit_grid().view(), coupling.perm().data(), sheet,
                               extent_.data(), coupling.near_flags(f.n), hits, sums_.data(), dt,
                               T(3) * coupling.skin() + coupling.flag_slack(), gap_},
        count, "coupling.sheet_guard");
  }
  if (ghost_sums) // every corner's count, from all ranks
    ghost_sums(sums_, true);
  if (meets)
    exec::for_each(ex, f.n,
                   SheetReactionEvaluator<T>{f.v, f.m, counted, hits, knit.v.data(), knit.m.data(),
                                             knit.handle.data(), sheet, sums_.data(),
                                             T(1) / quantum_},
                   "coupling.sheet_guard");
  // The ghosts' shares to their owners, and the totals back to the ghosts: every local point
  // takes its kick (a ghost's velocity stays its owner's, as the step's bounds read it).
  if (ghost_sums)
    ghost_sums(sums_, true);
  exec::for_each(ex, knit.size(),
                 SheetKickEvaluator<T>{knit.v.data(), knit.handle.data(), sums_.data(), quantum_},
                 "coupling.sheet_guard");
}

template class SheetGuard<float>;
template class SheetGuard<double>;

} // namespace kf
