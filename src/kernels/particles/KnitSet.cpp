#include "kernels/particles/KnitSet.hpp"

namespace kf {

namespace {
template <typename T, typename F>
void each_column(KnitSet<T>& s, F&& f) {
  f(s.x);
  f(s.v);
  f(s.a);
  f(s.x_rest);
  f(s.m);
  f(s.handle);
  f(s.layer);
  f(s.piece);
  f(s.id);
}
} // namespace

template <typename T>
KnitSet<T>::KnitSet(exec::Backend b)
    : x(b, 0, "knit.x"), v(b, 0, "knit.v"), a(b, 0, "knit.a"), x_rest(b, 0, "knit.x_rest"),
      m(b, 0, "knit.m"), handle(b, 0, "knit.handle"), layer(b, 0, "knit.layer"),
      piece(b, 0, "knit.piece"), id(b, 0, "knit.id") {}

template <typename T>
void KnitSet<T>::resize(std::size_t n) {
  each_column(*this, [n](auto& c) { c.resize_snug(n); });
}

template <typename T>
void KnitSet<T>::shrink_to_fit() {
  each_column(*this, [](auto& c) { c.shrink_to_fit(); });
}

template <typename T>
KnitView<T> KnitSet<T>::view() {
  return {x.data(), v.data(), a.data(), m.data(), handle.data(), size()};
}

template <typename T>
std::size_t KnitSet<T>::bytes_per_particle() {
  return 4 * sizeof(Vec3<T>) + sizeof(T) + sizeof(std::uint32_t) + sizeof(std::uint8_t) +
         sizeof(std::uint16_t) + sizeof(std::uint64_t);
}

template class KnitSet<float>;
template class KnitSet<double>;

} // namespace kf
