#include "kernels/coupling/SheetGuard.hpp"

#include "core/Error.hpp"

#include <cmath>
#include <string>

namespace kf {

template <typename T>
SheetGuard<T>::SheetGuard(exec::Backend b, const std::vector<std::array<std::uint32_t, 3>>& faces,
                          const std::vector<std::uint32_t>& offsets,
                          const std::vector<std::uint32_t>& ids, T gap)
    : vertex_(b, 0, "sheet_guard.vertex"), offsets_(b, 0, "sheet_guard.offsets"),
      ids_(b, 0, "sheet_guard.faces"), extent_(b, kSheetExtentValues, "sheet_guard.extent"),
      gap_(gap) {
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
void SheetGuard<T>::apply(const exec::Exec& ex, FluidView<T> f, T dt, const KnitSet<T>& knit,
                          const exec::DeviceBuffer<Vec3<T>>& knit_x0,
                          const KnitFluidCoupling<T>& coupling, const std::uint32_t* knit_of_id,
                          const std::uint32_t* counted, std::uint64_t* count) const {
  if (knit.size() == 0 || f.n == 0)
    return;
  if (knit_x0.size() != knit.size())
    throw Error("sheet guard: " + std::to_string(knit_x0.size()) +
                " knit positions at the step's start for " + std::to_string(knit.size()) +
                " points");
  const SheetFacesView sheet{vertex_.data(), offsets_.data(), ids_.data(), knit_of_id};
  const GridGeometry<T> geo = coupling.knit_grid().geometry();
  exec::fill(ex, extent_, T(0), "coupling.sheet_guard");
  exec::max_into_each<T, kSheetExtentValues>(
      ex, faces(), SheetExtent<T>{knit.x.data(), knit_x0.data(), sheet, geo}, extent_.data(),
      "coupling.sheet_guard");
  // The coupling grid's points moved at most three of its watch's skins since its sort (one
  // before the step, two in it: KnitFluidCoupling::begin_step).
  exec::transform_reduce_into(
      ex, f.n, exec::SumOp{},
      SheetGuardEvaluator<T>{f.x, f.v, counted, knit.x.data(), knit_x0.data(), knit.id.data(),
                             coupling.knit_grid().view(), coupling.perm().data(), sheet,
                             extent_.data(), coupling.near_flags(f.n), dt, T(3) * coupling.skin(),
                             gap_},
      count, "coupling.sheet_guard");
}

template class SheetGuard<float>;
template class SheetGuard<double>;

} // namespace kf
