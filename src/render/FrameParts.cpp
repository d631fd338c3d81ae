#include "render/FrameParts.hpp"

#include "comm/ByteExchange.hpp"
#include "core/Error.hpp"
#include "io/SnapshotReader.hpp"

#include <algorithm>
#include <cstring>
#include <limits>

namespace kf::render {

namespace {

std::uint64_t sum_over(MPI_Comm comm, std::uint64_t mine) {
  std::uint64_t all = 0;
  MPI_Allreduce(&mine, &all, 1, MPI_UINT64_T, MPI_SUM, comm);
  return all;
}

std::size_t row_bytes(const io::Field& f) {
  return std::size_t(f.components) * io::dtype_size(f.type);
}

/// A phase whole on every rank: each field's shares concatenated in rank order (the file's).
void gather_whole(MPI_Comm comm, io::Phase& p) {
  for (io::Field& f : p.fields) {
    f.bytes = comm::gather_bytes_to_all(comm, f.bytes);
    f.count = f.bytes.size() / row_bytes(f);
  }
}

void as_doubles(const glm::dvec3& v, double* out) {
  out[0] = v.x;
  out[1] = v.y;
  out[2] = v.z;
}

} // namespace

FramePart read_frame_part(MPI_Comm comm, const std::string& path, SnapshotRenderer& renderer) {
  int rank = 0, ranks = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &ranks);
  FramePart part;
  part.frame = io::read_snapshot_share(comm, path);
  io::Frame& f = part.frame;
  io::Phase* fluid = nullptr;
  for (io::Phase& p : f.phases)
    if (p.name == "fluid")
      fluid = &p;
    else
      gather_whole(comm, p);
  // The fluid's share: its place among all rows, the whole box and spacing.
  const std::vector<glm::dvec3> x = phase_positions(f, "fluid");
  const std::uint64_t mine = x.size(), total = sum_over(comm, mine);
  std::uint64_t first = 0;
  MPI_Exscan(&mine, &first, 1, MPI_UINT64_T, MPI_SUM, comm);
  if (rank == 0)
    first = 0;
  part.fluid_read = x.size();
  part.fluid_total = total;
  SnapshotRenderer::WholeFluid whole;
  whole.empty = total == 0;
  if (!whole.empty) {
    double lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::numeric_limits<double>::infinity();
      hi[a] = -lo[a];
    }
    for (const glm::dvec3& p : x)
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], p[a]);
        hi[a] = std::max(hi[a], p[a]);
      }
    MPI_Allreduce(MPI_IN_PLACE, lo, 3, MPI_DOUBLE, MPI_MIN, comm);
    MPI_Allreduce(MPI_IN_PLACE, hi, 3, MPI_DOUBLE, MPI_MAX, comm);
    whole.lo = {lo[0], lo[1], lo[2]};
    whole.hi = {hi[0], hi[1], hi[2]};
    if (!renderer.knows_fluid_spacing() && total > 1) {
      // typical_spacing over the ranks: the samples' places from their owners, each rank's
      // nearest to them, the least of all.
      const std::vector<std::size_t> at = spacing_samples(total);
      std::vector<double> places(3 * at.size(), 0.0);
      for (std::size_t s = 0; s < at.size(); ++s)
        if (at[s] >= first && at[s] < first + mine)
          as_doubles(x[at[s] - first], &places[3 * s]);
      MPI_Allreduce(MPI_IN_PLACE, places.data(), int(places.size()), MPI_DOUBLE, MPI_SUM, comm);
      std::vector<glm::dvec3> sample(at.size());
      for (std::size_t s = 0; s < at.size(); ++s)
        sample[s] = {places[3 * s], places[3 * s + 1], places[3 * s + 2]};
      std::vector<double> best(at.size(), std::numeric_limits<double>::infinity());
      nearest_to_samples(sample, at, x, first, best);
      MPI_Allreduce(MPI_IN_PLACE, best.data(), int(best.size()), MPI_DOUBLE, MPI_MIN, comm);
      whole.spacing = median_spacing(best);
    }
  }
  renderer.set_whole_fluid(whole);
  // The k-d split of the drawn points: the fluid's gathered (every k-th row of the file), the
  // rest as every rank holds it.
  const std::vector<glm::dvec3> others = renderer.drawn_points(f, false);
  constexpr std::uint64_t kMostSplitPoints = 2'000'000;
  const std::uint64_t stride = (total + others.size()) / kMostSplitPoints + 1;
  std::vector<unsigned char> picked;
  for (std::size_t i = 0; i < x.size(); ++i)
    if ((first + i) % stride == 0) {
      double v[3];
      as_doubles(x[i], v);
      picked.insert(picked.end(), reinterpret_cast<unsigned char*>(v),
                    reinterpret_cast<unsigned char*>(v) + sizeof v);
    }
  const std::vector<unsigned char> all = comm::gather_bytes_to_all(comm, picked);
  std::vector<glm::dvec3> points(all.size() / (3 * sizeof(double)));
  for (std::size_t i = 0; i < points.size(); ++i) {
    double v[3];
    std::memcpy(v, &all[i * sizeof v], sizeof v);
    points[i] = {v[0], v[1], v[2]};
  }
  for (std::size_t i = 0; i < others.size(); i += stride)
    points.push_back(others[i]);
  part.regions = kd_split(std::move(points), ranks);
  // The fluid's rows to the ranks whose region, grown by the halo, holds them.
  if (fluid) {
    const double halo = whole.empty ? 0.0 : renderer.fluid_halo(whole);
    std::size_t record = 0;
    for (const io::Field& field : fluid->fields) {
      if (field.count != x.size())
        throw Error(path + ": the fluid's " + field.name + " has " + std::to_string(field.count) +
                    " rows, its positions " + std::to_string(x.size()));
      record += row_bytes(field);
    }
    std::vector<std::vector<unsigned char>> to(static_cast<std::size_t>(ranks));
    for (std::size_t i = 0; i < x.size(); ++i)
      for (int r = 0; r < ranks; ++r) {
        const Region& g = part.regions[std::size_t(r)];
        const Region grown{g.lo - glm::dvec3(halo), g.hi + glm::dvec3(halo)};
        if (!grown.contains(x[i]))
          continue;
        std::vector<unsigned char>& out = to[std::size_t(r)];
        for (const io::Field& field : fluid->fields) {
          const std::size_t b = row_bytes(field);
          out.insert(out.end(), field.bytes.begin() + std::ptrdiff_t(i * b),
                     field.bytes.begin() + std::ptrdiff_t((i + 1) * b));
        }
      }
    const std::vector<unsigned char> in = comm::exchange_bytes(comm, to);
    const std::size_t rows = record > 0 ? in.size() / record : 0;
    for (io::Field& field : fluid->fields) {
      field.bytes.clear();
      field.bytes.reserve(rows * row_bytes(field));
      field.count = rows;
    }
    for (std::size_t k = 0, at = 0; k < rows; ++k)
      for (io::Field& field : fluid->fields) {
        const std::size_t b = row_bytes(field);
        field.bytes.insert(field.bytes.end(), in.begin() + std::ptrdiff_t(at),
                           in.begin() + std::ptrdiff_t(at + b));
        at += b;
      }
    part.fluid_held = rows;
  }
  return part;
}

} // namespace kf::render
