// SimulationT<T>'s watchdog reading (one pass over each set on the device, one small read) and
// its report on the worst particle (host copies: only when the watchdog trips).
#include "domain/SimulationT.hpp"

#include <sstream>

namespace kf {

namespace {

/// The domain's corner lowest along g: heights above it are never negative inside the domain.
Vec3d lowest_corner(const Scene& s) {
  const Vec3d& g = s.gravity;
  return {g.x < 0 ? s.domain.min.x : s.domain.max.x, g.y < 0 ? s.domain.min.y : s.domain.max.y,
          g.z < 0 ? s.domain.min.z : s.domain.max.z};
}

} // namespace

template <typename T>
double SimulationT<T>::work_done() const {
  double w = work_.size() ? work_.host_value(0) : 0.0;
  if (contact_work_.size())
    w += double(static_cast<std::int64_t>(contact_work_.host_value(0))) * contact_unit_;
  return w;
}

template <typename T>
WatchReading SimulationT<T>::watch() {
  if (watch_sums_.size() != 2) // made at the first reading: most runs read before they step
    watch_sums_ = exec::DeviceBuffer<WatchSums>(ex_.backend, 2, "watchdog");
  const Vec3<T> g = vec_cast<T>(scene_.gravity), ref = vec_cast<T>(lowest_corner(scene_));
  if (fluid_on_) {
    // Ghosts follow the fluid: the owned rows' flags where they are (a copy of them through the
    // host, 20 bytes a particle, cost the 4M-a-GPU dam break 0.2 ms a step at 50 steps a check).
    const std::uint32_t* owned =
        ranks_ && fluid_->size() != ranks_->fluid_owned_count() ? ranks_->owned_flags() : nullptr;
    auto f = fluid_->view();
    watch_sums_to(ex_, f.x, f.v, f.m, f.rho, owned, f.n, g, ref, watch_sums_.data(),
                  "watchdog.fluid");
  } else {
    watch_sums_to<T>(ex_, nullptr, nullptr, nullptr, nullptr, nullptr, 0, g, ref,
                     watch_sums_.data(), "watchdog.fluid");
  }
  if (knit_on_) {
    auto& set = knit_->set();
    watch_sums_to(ex_, set.x.data(), set.v.data(), set.m.data(), static_cast<const T*>(nullptr),
                  nullptr, knit_->owned(), g, ref, watch_sums_.data() + 1, "watchdog.knit");
  } else {
    watch_sums_to<T>(ex_, nullptr, nullptr, nullptr, nullptr, nullptr, 0, g, ref,
                     watch_sums_.data() + 1, "watchdog.knit");
  }
  const auto s = watch_sums_.to_host();
  double sums[5] = {s[0].mass + s[1].mass, s[0].kinetic + s[1].kinetic,
                    s[0].potential + s[1].potential, s[1].mass, work_done()};
  double maxima[3] = {nan_as_inf(s[0].max_speed2), nan_as_inf(s[0].max_density),
                      nan_as_inf(s[1].max_speed2)};
  if (ranks_) {
    MPI_Allreduce(MPI_IN_PLACE, sums, 5, MPI_DOUBLE, MPI_SUM, ranks_->mpi().comm());
    MPI_Allreduce(MPI_IN_PLACE, maxima, 3, MPI_DOUBLE, MPI_MAX, ranks_->mpi().comm());
  }
  WatchReading r;
  r.mass = sums[0];
  r.kinetic = sums[1];
  r.potential = sums[2];
  r.knit_mass = sums[3];
  r.work = sums[4];
  r.fluid_max_speed = std::sqrt(maxima[0]);
  r.fluid_max_density = maxima[1];
  r.knit_max_speed = std::sqrt(maxima[2]);
  return r;
}

template <typename T>
std::string SimulationT<T>::local_worst(WatchMeasure measure, double* worst_value) const {
  const bool fluid = measure != WatchMeasure::KnitSpeed;
  std::vector<Vec3<T>> x, v, a;
  std::vector<T> rho;
  std::vector<std::uint64_t> id;
  std::vector<std::uint8_t> own;
  if (fluid && fluid_on_) {
    x = fluid_->x.to_host();
    v = fluid_->v.to_host();
    a = fluid_->a.to_host();
    rho = fluid_->rho.to_host();
    id = fluid_->id.to_host();
    own = fluid_owned_rows();
  } else if (!fluid && knit_on_) {
    auto& set = const_cast<KnitSystem<T>&>(*knit_).set();
    const std::size_t n = knit_->owned();
    x = set.x.to_host();
    v = set.v.to_host();
    a = set.a.to_host();
    id = set.id.to_host();
    for (auto* f : {&x, &v, &a})
      f->resize(n);
    id.resize(n);
    own.assign(n, 1);
  }
  // The measure; a non-finite speed, acceleration or density counts as infinite.
  auto value = [&](std::size_t i) {
    const double s =
        measure == WatchMeasure::FluidDensity ? double(rho[i]) : std::sqrt(double(norm2(v[i])));
    const bool finite = std::isfinite(s) && std::isfinite(double(norm2(a[i]))) &&
                        std::isfinite(double(norm2(x[i])));
    return finite ? s : std::numeric_limits<double>::infinity();
  };
  double best = -1;
  std::size_t at = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (own[i] && value(i) > best) {
      best = value(i);
      at = i;
    }
  *worst_value = best;
  if (best < 0)
    return "";
  // The neighbourhood: the same set's particles within the support radius (the knit: about
  // its springs' reach). Brute force: this runs once, when the run is going wrong.
  const double reach = fluid ? h_ : 1.5 * knit_->longest_spacing();
  const Vec3d c = vec_cast<double>(x[at]);
  std::size_t near = 0;
  double vmin = std::numeric_limits<double>::infinity(), vmax = 0, rmin = vmin, rmax = 0;
  for (std::size_t j = 0; j < x.size(); ++j) {
    if (j == at || !(norm(vec_cast<double>(x[j]) - c) <= reach))
      continue;
    ++near;
    const double s = std::sqrt(double(norm2(v[j])));
    vmin = std::min(vmin, s);
    vmax = std::max(vmax, s);
    if (fluid) {
      rmin = std::min(rmin, double(rho[j]));
      rmax = std::max(rmax, double(rho[j]));
    }
  }
  std::ostringstream o;
  o << (fluid ? "fluid particle id " : "knit point id ") << id[at] << " at (" << c.x << ", " << c.y
    << ", " << c.z << ")" << (ranks_ ? " on rank " + std::to_string(ranks_->rank()) : "")
    << ": |v| = " << std::sqrt(double(norm2(v[at])))
    << " m/s, |a| = " << std::sqrt(double(norm2(a[at]))) << " m/s^2";
  if (fluid)
    o << ", rho = " << rho[at] << " kg/m^3";
  o << "; " << near << " neighbours within " << reach << " m";
  if (near) {
    o << " (|v| " << vmin << " to " << vmax << " m/s";
    if (fluid)
      o << ", rho " << rmin << " to " << rmax << " kg/m^3";
    o << ")";
  }
  return o.str();
}

template <typename T>
std::string SimulationT<T>::describe_worst(WatchMeasure measure) const {
  struct {
    double value;
    int rank;
  } worst{-1, ranks_ ? ranks_->rank() : 0};
  std::string text = local_worst(measure, &worst.value);
  if (ranks_) { // the text from the rank that holds the particle to every rank
    const int mine = worst.rank;
    MPI_Allreduce(MPI_IN_PLACE, &worst, 1, MPI_DOUBLE_INT, MPI_MAXLOC, ranks_->mpi().comm());
    if (worst.rank != mine)
      text.clear();
    unsigned long n = text.size();
    MPI_Bcast(&n, 1, MPI_UNSIGNED_LONG, worst.rank, ranks_->mpi().comm());
    text.resize(n);
    MPI_Bcast(text.data(), int(n), MPI_CHAR, worst.rank, ranks_->mpi().comm());
  }
  return text;
}

template double SimulationT<float>::work_done() const;
template double SimulationT<double>::work_done() const;
template WatchReading SimulationT<float>::watch();
template std::string SimulationT<float>::describe_worst(WatchMeasure) const;
template std::string SimulationT<float>::local_worst(WatchMeasure, double*) const;
template WatchReading SimulationT<double>::watch();
template std::string SimulationT<double>::describe_worst(WatchMeasure) const;
template std::string SimulationT<double>::local_worst(WatchMeasure, double*) const;

} // namespace kf
