// Ghosts and migration over real ranks (mpiexec -n 2, and 3): every rank makes the same global
// set of particles (seeded), keeps those its blocks own, and then
// - every particle is owned by exactly one rank;
// - the ghosts a rank receives are exactly the particles of other ranks within the ghost width of
//   its region, by a brute-force distance to each of its blocks, with their values; also where
//   flagged particles take a wider width (the fluid beside walls);
// - the reverse of a refresh (add_to_owners) adds each ghost's values into its owner's row,
//   against a brute-force count over every rank's ghosts;
// - after the particles move, migration keeps the count, the ids, the masses and every other
//   column, and leaves each particle on the rank that owns its block;
// - a skewed start (all particles in one corner of a partition made for a uniform load) is
//   re-partitioned by the measured counts and migrated below the default threshold of 1.1;
// - a device backend's copier (DeviceRows: packing by kernels, staged through the host) moves
//   the same bytes as the host's, for refreshes into contiguous and into remapped ghost slots and
//   for a migration, also one dropping rows by flags on the backend (on the CPU backend here
//   and in CI, and on CUDA where a GPU is visible: staged through page-locked host messages for
//   MPI, and kept in device memory for NCCL where every rank has a GPU of its own).
#include "comm/HaloExchange.hpp"
#include "comm/MpiContext.hpp"
#include "comm/Transport.hpp"
#include "core/Error.hpp"
#include "domain/Decomposition.hpp"
#include "domain/DeviceRows.hpp"
#include "domain/ExchangeColumns.hpp"
#include "domain/GhostSelection.hpp"
#include "support/MpiGather.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cstring>
#include <numeric>
#include <random>

using namespace kf;

namespace {

struct Particles {
  std::vector<Vec3d> x;
  std::vector<std::uint64_t> id;
  std::vector<double> m;
};

Particles global_set(std::size_t n, const Vec3d& lo, const Vec3d& hi, std::uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Particles p;
  for (std::size_t i = 0; i < n; ++i) {
    p.x.push_back({lo.x + u(rng) * (hi.x - lo.x), lo.y + u(rng) * (hi.y - lo.y),
                   lo.z + u(rng) * (hi.z - lo.z)});
    p.id.push_back(1000 + 7 * i); // not 0..n-1: ids are labels, not indices
    p.m.push_back(1.0 + 1e-3 * double(i % 97));
  }
  return p;
}

std::vector<std::array<double, kPhases>> counts_of(const BlockGrid& g,
                                                   const std::vector<Vec3d>& x) {
  std::vector<std::array<double, kPhases>> c(g.count(), {0, 0, 0});
  for (const Vec3d& q : x)
    c[g.block_of(q)][0] += 1;
  return c;
}

Particles owned_part(const Particles& all, const Decomposition& d, int me) {
  Particles p;
  for (std::size_t i = 0; i < all.x.size(); ++i)
    if (d.owner(all.x[i]) == me) {
      p.x.push_back(all.x[i]);
      p.id.push_back(all.id[i]);
      p.m.push_back(all.m[i]);
    }
  return p;
}

std::vector<std::uint64_t> all_ids(const std::vector<std::uint64_t>& mine) {
  auto out = test::allgather(mine);
  std::sort(out.begin(), out.end());
  return out;
}

template <typename V>
std::vector<unsigned char> bytes_of(const std::vector<V>& v) {
  std::vector<unsigned char> b(v.size() * sizeof(V));
  if (!b.empty()) // the skewed start leaves ranks empty: memcpy takes no null pointer
    std::memcpy(b.data(), v.data(), b.size());
  return b;
}
template <typename V>
std::vector<V> from_bytes(const std::vector<unsigned char>& b) {
  std::vector<V> v(b.size() / sizeof(V));
  if (!v.empty())
    std::memcpy(v.data(), b.data(), b.size());
  return v;
}

} // namespace

class Halo : public ::testing::Test {
protected:
  comm::MpiContext mpi;
  std::unique_ptr<comm::Transport> t =
      comm::make_transport(mpi, comm::TransportKind::Mpi, comm::MemorySpace::Host);

  /// 6,000 particles spread over a 0.6 x 0.3 x 0.4 box of 0.05 blocks, split over the ranks by
  /// their counts: the decomposition and this rank's part.
  struct Uniform {
    Particles all;
    Decomposition d;
    Particles mine;
  };
  Uniform uniform(std::uint32_t seed) const {
    const Vec3d lo{0, 0, 0}, hi{0.6, 0.3, 0.4};
    const BlockGrid g(lo, hi, 0.05);
    Particles all = global_set(6000, lo, hi, seed);
    Decomposition d =
        Decomposition::partition(g, counts_of(g, all.x), PhaseCosts{}, mpi.size(), 0.02);
    Particles mine = owned_part(all, d, mpi.rank());
    return {std::move(all), std::move(d), std::move(mine)};
  }
};

TEST_F(Halo, GhostsAreExactlyTheParticlesWithinTheWidthOfTheRegion) {
  const auto [all, d, mine] = uniform(11);
  // Owned once: the ids over all ranks are the global ids, each once.
  EXPECT_EQ(all_ids(mine.id), std::vector<std::uint64_t>(all.id));
  // Every third particle (by id) flagged "beside walls": with a wider width it goes that far
  // (RankExchange's fluid beside walls), the others their width.
  const auto flagged = [](std::uint64_t id) { return (id / 7) % 3 == 0; };
  std::vector<std::uint8_t> beside;
  for (std::uint64_t id : mine.id)
    beside.push_back(flagged(id) ? 1 : 0);
  const std::pair<double, double> widths[] = {{0.013, 0}, {0.05, 0}, {0.08, 0}, {0.013, 0.05}};
  for (const auto& [width, wider] : widths) {
    const GhostLists gl = select_ghosts(d, mpi.rank(), mine.x, width,
                                        wider > 0 ? beside : std::vector<std::uint8_t>{}, wider);
    const auto width_of = [&, width = width, wider = wider](std::uint64_t id) {
      return wider > 0 && flagged(id) ? std::max(width, wider) : width;
    };
    comm::HaloExchange ex(*t, gl.peers, gl.send);
    const std::size_t n = mine.x.size(), ng = ex.received();
    std::vector<Vec3d> x(n + ng, Vec3d{std::nan(""), 0, 0});
    std::vector<std::uint64_t> id(n + ng, ~0ull);
    std::copy(mine.x.begin(), mine.x.end(), x.begin());
    std::copy(mine.id.begin(), mine.id.end(), id.begin());
    const comm::Column cols[] = {{x.data(), sizeof(Vec3d)}, {id.data(), sizeof(std::uint64_t)}};
    ex.exchange(cols, n);
    // The brute-force set: every particle of another rank within the width of this region.
    std::vector<std::uint64_t> want;
    for (std::size_t i = 0; i < all.x.size(); ++i)
      if (d.owner(all.x[i]) != mpi.rank() &&
          d.distance_to_region(all.x[i], mpi.rank()) < width_of(all.id[i]))
        want.push_back(all.id[i]);
    std::sort(want.begin(), want.end());
    std::vector<std::uint64_t> got(id.begin() + n, id.end());
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, want) << "rank " << mpi.rank() << ", width " << width << ", wider " << wider;
    EXPECT_GT(got.size(), 0u);
    // The border a pass computes before the exchange starts: exactly the owned particles within
    // the width of another rank's region, each once, ascending.
    std::vector<std::uint32_t> border;
    for (std::size_t i = 0; i < n; ++i)
      for (int r = 0; r < mpi.size(); ++r)
        if (r != mpi.rank() && d.distance_to_region(mine.x[i], r) < width_of(mine.id[i])) {
          border.push_back(static_cast<std::uint32_t>(i));
          break;
        }
    // (sent_rows lists a row once per peer it goes to: as a set.)
    std::vector<std::uint32_t> sent = ex.sent_rows();
    std::sort(sent.begin(), sent.end());
    sent.erase(std::unique(sent.begin(), sent.end()), sent.end());
    EXPECT_EQ(sent, border) << "rank " << mpi.rank() << ", width " << width << ", wider " << wider;
    // And each ghost carries its particle's position, bit for bit.
    for (std::size_t k = n; k < n + ng; ++k) {
      const std::size_t i = (id[k] - 1000) / 7;
      ASSERT_LT(i, all.x.size());
      EXPECT_EQ(std::memcmp(&x[k], &all.x[i], sizeof(Vec3d)), 0) << "ghost " << id[k];
    }
    if (mpi.root())
      std::printf("width %.3f (wider %.3f): rank 0 owns %zu, receives %zu ghosts from %zu "
                  "peer(s)\n",
                  width, wider, n, ng, gl.peers.size());
  }
}

// The reverse of a refresh, summing (the tunnelling guard's reaction on the knit's corners):
// every row, owned or ghost, holds (1, 31 id + rank + 1); after add_to_owners each owned row
// holds its own plus, for every rank holding it as a ghost, that rank's, by a brute-force count
// over the ranks' ghost lists; and the ghosts' rows are left as they were.
TEST_F(Halo, SumsFromGhostsReachTheirOwners) {
  const auto [all, d, mine] = uniform(13);
  const GhostLists gl = select_ghosts(d, mpi.rank(), mine.x, 0.05);
  comm::HaloExchange ex(*t, gl.peers, gl.send);
  const std::size_t n = mine.x.size(), ng = ex.received();
  std::vector<std::uint64_t> id(n + ng, ~0ull);
  std::copy(mine.id.begin(), mine.id.end(), id.begin());
  const comm::Column cols[] = {{id.data(), sizeof(std::uint64_t)}};
  ex.exchange(cols, n);
  const auto me = static_cast<std::uint64_t>(mpi.rank());
  std::vector<std::uint64_t> sums(2 * (n + ng));
  for (std::size_t k = 0; k < n + ng; ++k) {
    sums[2 * k] = 1;
    sums[2 * k + 1] = 31 * id[k] + me + 1;
  }
  const std::vector<std::uint64_t> before = sums;
  ex.add_to_owners(sums, 2, n);
  // Every rank's ghosts, as id * 8 + rank.
  std::vector<std::uint64_t> held;
  for (std::size_t k = n; k < n + ng; ++k)
    held.push_back(id[k] * 8 + me);
  const std::vector<std::uint64_t> ghosts = test::allgather(held);
  std::size_t shared = 0;
  for (std::size_t k = 0; k < n; ++k) {
    std::uint64_t count = 1, value = 31 * id[k] + me + 1;
    for (std::uint64_t g8 : ghosts)
      if (g8 / 8 == id[k]) {
        ++count;
        value += 31 * id[k] + g8 % 8 + 1;
      }
    shared += count > 1;
    EXPECT_EQ(sums[2 * k], count) << "particle " << id[k] << " on rank " << me;
    EXPECT_EQ(sums[2 * k + 1], value) << "particle " << id[k] << " on rank " << me;
  }
  for (std::size_t k = n; k < n + ng; ++k)
    EXPECT_EQ(sums[2 * k + 1], before[2 * k + 1]) << "ghost " << id[k];
  EXPECT_GT(shared, 0u) << "no owned particle is another rank's ghost: the case tests nothing";
  // Sums too short for the rows are refused, naming them.
  std::vector<std::uint64_t> short_sums(2 * n);
  if (ng > 0) {
    EXPECT_THROW(ex.add_to_owners(short_sums, 2, n), Error);
  }
}

TEST_F(Halo, MigrationKeepsEveryParticleAndItsColumnsOnItsNewOwner) {
  const Vec3d lo{0, 0, 0}, hi{0.6, 0.3, 0.4};
  const BlockGrid g(lo, hi, 0.05);
  const Particles all = global_set(5000, lo, hi, 12);
  const Decomposition d =
      Decomposition::partition(g, counts_of(g, all.x), PhaseCosts{}, mpi.size(), 0.02);
  Particles mine = owned_part(all, d, mpi.rank());
  double mass0 = 0;
  for (double m : mine.m)
    mass0 += m;
  mass0 = mpi.sum(mass0);
  // Everyone moves up to a block and a half in each direction (kept in the box).
  std::mt19937_64 rng(99 + mpi.rank());
  std::uniform_real_distribution<double> u(-0.075, 0.075);
  for (Vec3d& q : mine.x)
    q = {std::clamp(q.x + u(rng), 0.0, 0.6), std::clamp(q.y + u(rng), 0.0, 0.3),
         std::clamp(q.z + u(rng), 0.0, 0.4)};
  std::vector<int> dest(mine.x.size());
  for (std::size_t i = 0; i < dest.size(); ++i)
    dest[i] = d.owner(mine.x[i]);
  // The moves reach at most two blocks: the peers of a 2-block reach.
  const auto peers = neighbour_ranks(d, mpi.rank(), 2 * g.edge());
  auto bx = bytes_of(mine.x);
  auto bid = bytes_of(mine.id);
  auto bm = bytes_of(mine.m);
  const comm::ByteColumn cols[] = {{&bx, sizeof(Vec3d)}, {&bid, 8}, {&bm, 8}};
  const std::size_t n = comm::migrate(*t, peers, dest, cols);
  const auto x = from_bytes<Vec3d>(bx);
  const auto id = from_bytes<std::uint64_t>(bid);
  const auto m = from_bytes<double>(bm);
  ASSERT_EQ(x.size(), n);
  ASSERT_EQ(id.size(), n);
  ASSERT_EQ(m.size(), n);
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_EQ(d.owner(x[i]), mpi.rank()) << "particle " << id[i] << " on the wrong rank";
    const std::size_t k = (id[i] - 1000) / 7;
    EXPECT_EQ(m[i], all.m[k]) << "particle " << id[i] << " lost its mass";
  }
  EXPECT_EQ(all_ids(id), std::vector<std::uint64_t>(all.id)) << "a particle was lost or doubled";
  double mass = 0;
  for (double v : m)
    mass += v;
  EXPECT_NEAR(mpi.sum(mass), mass0, 1e-12 * mass0);
  const std::uint64_t moved = mpi.sum(std::uint64_t(
      std::count_if(dest.begin(), dest.end(), [&](int r) { return r != mpi.rank(); })));
  if (mpi.root())
    std::printf("%llu particles changed rank\n", static_cast<unsigned long long>(moved));
  EXPECT_GT(moved, 100u);
}

TEST_F(Halo, ASkewedStartIsRebalancedBelowTheThreshold) {
  const Vec3d lo{0, 0, 0}, hi{1, 1, 1};
  const BlockGrid g(lo, hi, 0.05);
  // The partition was made for a uniform load; then all the particles sit in one corner.
  const Particles uniform = global_set(8000, lo, hi, 13);
  const Decomposition before =
      Decomposition::partition(g, counts_of(g, uniform.x), PhaseCosts{}, mpi.size(), 0.02);
  const Particles all = global_set(8000, lo, {0.3, 0.3, 0.3}, 14);
  Particles mine = owned_part(all, before, mpi.rank());
  auto local_counts = counts_of(g, mine.x);
  std::vector<double> flat(g.count()), sum(g.count());
  for (int b = 0; b < g.count(); ++b)
    flat[b] = local_counts[b][0];
  MPI_Allreduce(flat.data(), sum.data(), g.count(), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  std::vector<std::array<double, kPhases>> counts(g.count(), {0, 0, 0});
  for (int b = 0; b < g.count(); ++b)
    counts[b][0] = sum[b];
  const double skew = Decomposition::imbalance(before.rank_costs(counts, PhaseCosts{}));
  const Decomposition after = Decomposition::partition(g, counts, PhaseCosts{}, mpi.size(), 0.02);
  std::vector<int> dest(mine.x.size());
  for (std::size_t i = 0; i < dest.size(); ++i)
    dest[i] = after.owner(mine.x[i]);
  // After a re-partition a particle may go anywhere: every rank is a peer.
  std::vector<int> peers;
  for (int r = 0; r < mpi.size(); ++r)
    if (r != mpi.rank())
      peers.push_back(r);
  auto bx = bytes_of(mine.x);
  auto bid = bytes_of(mine.id);
  const comm::ByteColumn cols[] = {{&bx, sizeof(Vec3d)}, {&bid, 8}};
  const std::size_t n = comm::migrate(*t, peers, dest, cols);
  std::vector<double> per(mpi.size(), 0.0);
  per[mpi.rank()] = double(n);
  MPI_Allreduce(MPI_IN_PLACE, per.data(), mpi.size(), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  const double imb = Decomposition::imbalance(per);
  if (mpi.root())
    std::printf("imbalance %.3f before, %.3f after re-partition and migration\n", skew, imb);
  EXPECT_GT(skew, 1.5) << "the start is not skewed: the test tests little";
  EXPECT_LT(imb, 1.1);
  EXPECT_EQ(all_ids(from_bytes<std::uint64_t>(bid)), std::vector<std::uint64_t>(all.id));
}

TEST_F(Halo, DeviceRowsMoveTheSameBytesAsTheHost) {
  const Vec3d lo{0, 0, 0}, hi{0.6, 0.3, 0.4};
  const BlockGrid g(lo, hi, 0.05);
  const Particles all = global_set(4000, lo, hi, 15);
  const Decomposition d =
      Decomposition::partition(g, counts_of(g, all.x), PhaseCosts{}, mpi.size(), 0.02);
  const Particles mine = owned_part(all, d, mpi.rank());
  const std::size_t n = mine.x.size();
  const GhostLists gl = select_ghosts(d, mpi.rank(), mine.x, 0.04);
  // Each way: the host copier; on a GPU, device packing staged through page-locked host
  // messages (MPI) and device messages: over NCCL where every rank has a GPU of its own, over
  // CUDA IPC where ranks of this node share them.
  struct Way {
    exec::Backend backend;
    comm::Transport* transport;
    bool device_messages;
  };
  std::vector<Way> ways{{exec::Backend::Cpu, t.get(), false}};
  std::unique_ptr<comm::Transport> device;
  if (exec::cuda_available()) {
    ways.push_back({exec::Backend::Cuda, t.get(), false});
    device = comm::make_transport(mpi, comm::TransportKind::Auto, comm::MemorySpace::Device);
    if (device->memory_space() == comm::MemorySpace::Device)
      ways.push_back({exec::Backend::Cuda, device.get(), true});
  }
  for (const Way& way : ways) {
    const exec::Backend b = way.backend;
    const std::string name =
        std::string(exec::to_string(b)) +
        (way.device_messages ? " over " + std::string(way.transport->name()) : "");
    SCOPED_TRACE(name);
    // The reference: the host's copier on host vectors.
    comm::HaloExchange host(*t, gl.peers, gl.send);
    const std::size_t ng = host.received();
    std::vector<Vec3d> hx(mine.x);
    std::vector<std::uint64_t> hid(mine.id);
    hx.resize(n + ng, Vec3d{std::nan(""), 0, 0});
    hid.resize(n + ng, ~0ull);
    // The same on the backend's buffers, poisoned where the ghosts go.
    DeviceRows rows(b, way.device_messages);
    comm::HaloExchange dev(*way.transport, gl.peers, gl.send, rows);
    exec::DeviceBuffer<Vec3d> dx(b, 0, "test.x");
    exec::DeviceBuffer<std::uint64_t> did(b, 0, "test.id");
    dx.assign(hx);
    did.assign(hid);
    const comm::Column hc[] = {{hx.data(), sizeof(Vec3d)}, {hid.data(), 8}};
    const comm::Column dc[] = {column(dx), column(did)};
    host.exchange(hc, n);
    dev.exchange(dc, n);
    EXPECT_EQ(bytes_of(dx.to_host()), bytes_of(hx));
    EXPECT_EQ(bytes_of(did.to_host()), bytes_of(hid));
    // Reordered (the ghosts' slots scattered among the owned): a reversal, then a refresh of
    // poisoned ghost slots lands each value where its particle went.
    std::vector<std::uint32_t> rev(n + ng);
    for (std::size_t k = 0; k < rev.size(); ++k)
      rev[k] = static_cast<std::uint32_t>(rev.size() - 1 - k);
    std::reverse(hx.begin(), hx.end());
    std::reverse(hid.begin(), hid.end());
    const auto expect_x = hx;
    for (std::size_t k = 0; k < ng; ++k)
      hx[rev[n + k]] = Vec3d{std::nan(""), 0, 0};
    dx.assign(hx);
    exec::DeviceBuffer<std::uint32_t> drev(b, 0, "test.rev");
    drev.assign(rev);
    host.remap({rev.data(), sizeof(std::uint32_t)}, n);
    dev.remap(column(drev), n);
    const comm::Column hc1[] = {{hx.data(), sizeof(Vec3d)}};
    const comm::Column dc1[] = {column(dx)};
    host.exchange(hc1, n);
    dev.exchange(dc1, n);
    EXPECT_EQ(bytes_of(hx), bytes_of(expect_x));
    EXPECT_EQ(bytes_of(dx.to_host()), bytes_of(expect_x));
    // The device copier mapped its own copies of the lists (nothing through the host): they come
    // back as the host's, and a second reordering (a rotation by a third) maps them again.
    EXPECT_EQ(dev.sent_rows(), host.sent_rows());
    exec::DeviceBuffer<std::uint32_t> dsent(b, host.sent(), "test.sent");
    dev.copy_sent_rows(dsent.data());
    EXPECT_EQ(dsent.to_host(), host.sent_rows());
    std::vector<std::uint32_t> rot(n + ng);
    for (std::size_t k = 0; k < rot.size(); ++k)
      rot[k] = static_cast<std::uint32_t>((k + rot.size() / 3) % rot.size());
    std::vector<Vec3d> turned(hx.size());
    for (std::size_t k = 0; k < hx.size(); ++k)
      turned[rot[k]] = hx[k];
    std::copy(turned.begin(), turned.end(), hx.begin()); // hc1 points at hx's storage
    const auto expect_turned = hx;
    for (std::size_t k = 0; k < ng; ++k) // the ghosts' slots, where they went twice
      hx[rot[rev[n + k]]] = Vec3d{std::nan(""), 0, 0};
    dx.assign(hx);
    drev.assign(rot);
    host.remap({rot.data(), sizeof(std::uint32_t)}, n);
    dev.remap(column(drev), n);
    host.exchange(hc1, n);
    dev.exchange(dc1, n);
    EXPECT_EQ(bytes_of(hx), bytes_of(expect_turned));
    EXPECT_EQ(bytes_of(dx.to_host()), bytes_of(expect_turned));
    EXPECT_EQ(dev.sent_rows(), host.sent_rows());
    // A migration: every third particle to the next rank, the rest stay.
    std::vector<int> dest(n);
    for (std::size_t i = 0; i < n; ++i)
      dest[i] = i % 3 == 0 ? (mpi.rank() + 1) % mpi.size() : mpi.rank();
    std::vector<int> peers;
    for (int r : {(mpi.rank() + 1) % mpi.size(), (mpi.rank() + mpi.size() - 1) % mpi.size()})
      if (r != mpi.rank() && std::find(peers.begin(), peers.end(), r) == peers.end())
        peers.push_back(r);
    auto bx = bytes_of(mine.x), bid = bytes_of(mine.id);
    const comm::ByteColumn hcols[] = {{&bx, sizeof(Vec3d)}, {&bid, 8}};
    const std::size_t nh = comm::migrate(*t, peers, dest, hcols);
    dx.assign(mine.x);
    did.assign(mine.id);
    auto dcols = ExchangeColumns::of(dx, did).migration;
    const std::size_t nd = comm::migrate(*way.transport, peers, dest, dcols, rows);
    ASSERT_EQ(nh, nd);
    EXPECT_EQ(bytes_of(dx.to_host()), bx);
    EXPECT_EQ(bytes_of(did.to_host()), bid);
    EXPECT_EQ(all_ids(from_bytes<std::uint64_t>(bid)), std::vector<std::uint64_t>(all.id));
    // The same migration dropping, besides, every fifth staying particle without a message (a
    // ghost held: Departures::keep, the flags on the backend, the dropped rows' indices never
    // listed): as the host's migration with those particles sent to -1.
    std::vector<int> dropping(dest);
    std::vector<std::uint32_t> stay(n);
    comm::Departures leaving;
    leaving.n = n;
    for (std::size_t i = 0; i < n; ++i) {
      if (dest[i] == mpi.rank() && i % 5 == 1)
        dropping[i] = -1;
      stay[i] = dropping[i] == mpi.rank() ? 1u : 0u;
      if (dest[i] != mpi.rank()) {
        leaving.index.push_back(static_cast<std::uint32_t>(i));
        leaving.to.push_back(dest[i]);
      }
    }
    auto bx2 = bytes_of(mine.x), bid2 = bytes_of(mine.id);
    const comm::ByteColumn hcols2[] = {{&bx2, sizeof(Vec3d)}, {&bid2, 8}};
    const std::size_t nh2 = comm::migrate(*t, peers, dropping, hcols2);
    dx.assign(mine.x);
    did.assign(mine.id);
    exec::DeviceBuffer<std::uint32_t> dstay(b, 0, "test.stay");
    dstay.assign(stay);
    leaving.keep = dstay.data();
    auto dcols2 = ExchangeColumns::of(dx, did).migration;
    const std::size_t nd2 = comm::migrate(*way.transport, peers, leaving, dcols2, rows);
    ASSERT_EQ(nh2, nd2);
    EXPECT_LT(nd2, nd); // some were dropped
    EXPECT_EQ(bytes_of(dx.to_host()), bx2);
    EXPECT_EQ(bytes_of(did.to_host()), bid2);
    // And the host's copier dropping by the same flags (a CPU run's path).
    std::vector<Vec3d> kx(mine.x);
    std::vector<std::uint64_t> kid(mine.id);
    std::vector<comm::MigrationColumn> kcols{{sizeof(Vec3d),
                                              [&](std::size_t m) {
                                                kx.resize(m);
                                                return reinterpret_cast<unsigned char*>(kx.data());
                                              }},
                                             {8, [&](std::size_t m) {
                                                kid.resize(m);
                                                return reinterpret_cast<unsigned char*>(kid.data());
                                              }}};
    leaving.keep = stay.data();
    EXPECT_EQ(comm::migrate(*t, peers, leaving, kcols), nh2);
    EXPECT_EQ(bytes_of(kx), bx2);
    EXPECT_EQ(bytes_of(kid), bid2);
    // In place (a rebuild's, the sort dropping the rest): the n rows untouched, the arrivals
    // after them; the rows flagged to stay, then the arrivals, are the compacted migration's.
    dx.assign(mine.x);
    did.assign(mine.id);
    leaving.keep = dstay.data();
    leaving.in_place = true;
    auto dcols3 = ExchangeColumns::of(dx, did).migration;
    const std::size_t nd3 = comm::migrate(*way.transport, peers, leaving, dcols3, rows);
    const std::size_t stayed = std::count(stay.begin(), stay.end(), 1u);
    ASSERT_EQ(nd3, n + (nd2 - stayed));
    const auto px = dx.to_host();
    const auto pid = did.to_host();
    EXPECT_EQ(bytes_of(std::vector<Vec3d>(px.begin(), px.begin() + n)), bytes_of(mine.x));
    std::vector<Vec3d> closed;
    std::vector<std::uint64_t> closed_id;
    for (std::size_t i = 0; i < nd3; ++i)
      if (i >= n || stay[i]) {
        closed.push_back(px[i]);
        closed_id.push_back(pid[i]);
      }
    EXPECT_EQ(bytes_of(closed), bx2);
    EXPECT_EQ(bytes_of(closed_id), bid2);
    leaving.keep = nullptr; // in place needs the flags
    EXPECT_THROW(comm::migrate(*way.transport, peers, leaving, dcols3, rows), Error);
    leaving.in_place = false;
    if (mpi.root())
      std::printf("%s: %zu ghosts, %zu after migration, same bytes as the host's\n", name.c_str(),
                  ng, nd);
  }
}
