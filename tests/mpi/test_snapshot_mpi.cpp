// Snapshots on two ranks: collective writes with a rank that owns no rows, global datasets in
// rank order, and even shares on read.
#include "../support/TestPaths.hpp"
#include "core/Error.hpp"
#include "io/SnapshotReader.hpp"
#include "io/SnapshotWriter.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <numeric>
#include <sstream>

using namespace kf::io;

namespace {

int comm_rank() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

int comm_size() {
  int n = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &n);
  return n;
}

/// `rows` rows per field, valued by the owning rank so that the order of rows is checkable.
Phase phase_rows(const std::string& name, int rank, std::size_t rows) {
  std::vector<float> position(3 * rows);
  std::vector<double> density(rows);
  std::vector<std::uint64_t> id(rows);
  std::vector<std::int32_t> flags(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    for (int c = 0; c < 3; ++c)
      position[3 * i + c] = float(100 * rank + 10 * i + c) + 0.1f;
    density[i] = 1000.0 + rank + 1e-3 * double(i);
    id[i] = (std::uint64_t(rank) << 40) + i;
    flags[i] = -int(i) - 10 * rank;
  }
  return {name,
          {Field::from("position", position, 3), Field::from("density", density, 1),
           Field::from("id", id, 1), Field::from("flags", flags, 1)}};
}

/// What `rank` owns: fluid only on rank 0 (5 rows), knit on every rank (3 + rank rows).
Frame rank_frame(int rank) {
  Frame f;
  f.index = 7;
  f.time = 0.75;
  f.step = 700;
  f.precision = "float";
  f.scene_text = "[scene]\n";
  f.scalars = {{"dt", 1e-4}};
  f.phases = {phase_rows("fluid", rank, rank == 0 ? 5 : 0), phase_rows("knit", rank, 3 + rank)};
  return f;
}

/// Rows [first, first + count) of a field.
Field slice(const Field& f, std::size_t first, std::size_t count) {
  Field s = f;
  const std::size_t row = f.components * dtype_size(f.type);
  s.count = count;
  s.bytes.assign(f.bytes.begin() + first * row, f.bytes.begin() + (first + count) * row);
  return s;
}

/// Rows of every rank's frame concatenated in rank order: what the global file must hold.
Frame concatenated(int ranks) {
  Frame all = rank_frame(0);
  for (int r = 1; r < ranks; ++r) {
    const Frame other = rank_frame(r);
    for (std::size_t p = 0; p < all.phases.size(); ++p)
      for (std::size_t i = 0; i < all.phases[p].fields.size(); ++i) {
        Field& dst = all.phases[p].fields[i];
        const Field& src = other.phases[p].fields[i];
        dst.bytes.insert(dst.bytes.end(), src.bytes.begin(), src.bytes.end());
        dst.count += src.count;
      }
  }
  return all;
}

void expect_same_fields(const Phase& a, const Phase& b) {
  EXPECT_EQ(a.name, b.name);
  ASSERT_EQ(a.fields.size(), b.fields.size());
  for (std::size_t i = 0; i < a.fields.size(); ++i) {
    EXPECT_EQ(a.fields[i].name, b.fields[i].name);
    EXPECT_EQ(a.fields[i].type, b.fields[i].type);
    EXPECT_EQ(a.fields[i].components, b.fields[i].components);
    EXPECT_EQ(a.fields[i].count, b.fields[i].count) << a.name << "/" << a.fields[i].name;
    EXPECT_EQ(a.fields[i].bytes, b.fields[i].bytes) << a.name << "/" << a.fields[i].name;
  }
}

/// Every rank's bytes, concatenated in rank order on every rank.
std::vector<unsigned char> all_gather(const std::vector<unsigned char>& mine) {
  const int n = comm_size();
  std::vector<int> sizes(n), offsets(n);
  const int size = int(mine.size());
  MPI_Allgather(&size, 1, MPI_INT, sizes.data(), 1, MPI_INT, MPI_COMM_WORLD);
  std::exclusive_scan(sizes.begin(), sizes.end(), offsets.begin(), 0);
  std::vector<unsigned char> all(offsets.back() + sizes.back());
  MPI_Allgatherv(mine.data(), size, MPI_BYTE, all.data(), sizes.data(), offsets.data(), MPI_BYTE,
                 MPI_COMM_WORLD);
  return all;
}

std::string write_rank_frames(const std::string& test) {
  const auto dir = kf::test::scratch_dir(test);
  return SnapshotWriter(MPI_COMM_WORLD, dir.string()).write(rank_frame(comm_rank()));
}

} // namespace

TEST(SnapshotMpi, GlobalDatasetsConcatenateRanksInOrder) {
  ASSERT_EQ(comm_size(), 2);
  const std::string path = write_rank_frames("snapshot_mpi_global");
  const Frame back = read_snapshot(MPI_COMM_WORLD, path);
  const Frame expected = concatenated(comm_size());
  EXPECT_EQ(back.index, 7u);
  EXPECT_EQ(back.time, 0.75);
  ASSERT_EQ(back.scalars.size(), 1u);
  ASSERT_EQ(back.phases.size(), 2u);
  EXPECT_EQ(back.phases[0].fields[0].count, 5u);
  EXPECT_EQ(back.phases[1].fields[0].count, 7u);
  for (std::size_t p = 0; p < expected.phases.size(); ++p)
    expect_same_fields(expected.phases[p], back.phases[p]);
}

TEST(SnapshotMpi, SharesSplitEvenlyAndReassemble) {
  const std::string path = write_rank_frames("snapshot_mpi_share");
  const Frame share = read_snapshot_share(MPI_COMM_WORLD, path);
  const Frame expected = concatenated(comm_size());
  const int r = comm_rank(), n = comm_size();
  ASSERT_EQ(share.phases.size(), expected.phases.size());
  for (std::size_t p = 0; p < expected.phases.size(); ++p) {
    const Phase& whole = expected.phases[p];
    const std::size_t rows = whole.fields[0].count;
    const std::size_t first = rows * r / n, count = rows * (r + 1) / n - first;
    Phase mine{whole.name, {}};
    for (const Field& f : whole.fields)
      mine.fields.push_back(slice(f, first, count));
    expect_same_fields(mine, share.phases[p]);
    for (std::size_t i = 0; i < whole.fields.size(); ++i)
      EXPECT_EQ(all_gather(share.phases[p].fields[i].bytes), whole.fields[i].bytes);
  }
}

TEST(SnapshotMpi, IndexCountsEveryRanksRows) {
  const std::string path = write_rank_frames("snapshot_mpi_xdmf");
  std::ifstream in(std::filesystem::path(path).parent_path() / "snapshots.xmf");
  std::stringstream xmf;
  xmf << in.rdbuf();
  EXPECT_NE(xmf.str().find("NumberOfElements=\"5\""), std::string::npos);
  EXPECT_NE(xmf.str().find("NumberOfElements=\"7\""), std::string::npos);
  EXPECT_NE(xmf.str().find("Dimensions=\"5 3\""), std::string::npos);
}

TEST(SnapshotMpi, RanksDisagreeingOnFieldsFailEverywhere) {
  const auto dir = kf::test::scratch_dir("snapshot_mpi_disagree");
  SnapshotWriter writer(MPI_COMM_WORLD, dir.string());
  Frame f = rank_frame(comm_rank());
  if (comm_rank() == 1)
    f.phases[1].fields.pop_back();
  EXPECT_THROW(writer.write(f), kf::Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "frame_000007.h5"));
}
