// Snapshots on one rank: exact round trips, atomic writes, the XDMF index and restart behaviour.
#include "io/SnapshotHdf5.hpp"
#include "io/SnapshotReader.hpp"
#include "io/SnapshotWriter.hpp"
#include "support/TestPaths.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

using namespace kf::io;
namespace fs = std::filesystem;

namespace {

Frame sample_frame(std::uint64_t index, double time) {
  using F = std::numeric_limits<float>;
  using D = std::numeric_limits<double>;
  Frame f;
  f.index = index;
  f.time = time;
  f.step = 1000 * index + 7;
  f.precision = "float";
  f.scene_text = "[scene]\nname = \"pour & soak\" # <quoted>\n";
  f.scene_dir = index % 2 ? "/runs/sc\u00e8nes/pour & soak" : ""; // (empty: an older snapshot's)
  f.scalars = {{"dt", 1.25e-4}, {"energy", -3.5}, {"nan_scalar", D::quiet_NaN()}};
  const std::vector<float> pos = {0.f,
                                  -0.f,
                                  1.5f,
                                  F::quiet_NaN(),
                                  F::infinity(),
                                  -F::infinity(),
                                  F::denorm_min(),
                                  F::max(),
                                  F::lowest(),
                                  std::bit_cast<float>(0x7fc12345u),
                                  std::bit_cast<float>(0x7f800001u), // signalling NaN
                                  1e-40f};
  Phase fluid{
      "fluid",
      {Field::from("position", pos, 3),
       Field::from("density",
                   std::vector<double>{1000., D::denorm_min(), D::max(),
                                       std::bit_cast<double>(0x7ff8dead0000beefull)},
                   1),
       Field::from("id", std::vector<std::uint64_t>{0, 1, ~0ull, 1ull << 63}, 1),
       Field::from("flags", std::vector<std::int32_t>{-1, 0, 2147483647, -2147483647 - 1}, 1)}};
  Phase boundary{"boundary",
                 {Field::from("position", std::vector<float>{1, 2, 3, 4, 5, 6}, 3),
                  Field::from("id", std::vector<std::uint64_t>{10, 11}, 1),
                  Field::from("normal", std::vector<double>{0, 0, 1, 0, 1, 0}, 3)}};
  Phase knit{"knit",
             {Field::from("position", std::vector<float>{}, 3),
              Field::from("id", std::vector<std::uint64_t>{}, 1)}};
  f.phases = {fluid, boundary, knit};
  return f;
}

/// Byte-exact comparison (NaN payloads included), in order.
void expect_same(const Frame& a, const Frame& b) {
  EXPECT_EQ(std::bit_cast<std::uint64_t>(a.time), std::bit_cast<std::uint64_t>(b.time));
  EXPECT_EQ(a.step, b.step);
  EXPECT_EQ(a.index, b.index);
  EXPECT_EQ(a.precision, b.precision);
  EXPECT_EQ(a.scene_text, b.scene_text);
  EXPECT_EQ(a.scene_dir, b.scene_dir);
  ASSERT_EQ(a.scalars.size(), b.scalars.size());
  for (std::size_t i = 0; i < a.scalars.size(); ++i) {
    EXPECT_EQ(a.scalars[i].first, b.scalars[i].first);
    EXPECT_EQ(std::bit_cast<std::uint64_t>(a.scalars[i].second),
              std::bit_cast<std::uint64_t>(b.scalars[i].second));
  }
  ASSERT_EQ(a.phases.size(), b.phases.size());
  for (std::size_t p = 0; p < a.phases.size(); ++p) {
    const Phase &pa = a.phases[p], &pb = b.phases[p];
    EXPECT_EQ(pa.name, pb.name);
    ASSERT_EQ(pa.fields.size(), pb.fields.size()) << pa.name;
    for (std::size_t i = 0; i < pa.fields.size(); ++i) {
      const Field &fa = pa.fields[i], &fb = pb.fields[i];
      EXPECT_EQ(fa.name, fb.name);
      EXPECT_EQ(fa.type, fb.type) << pa.name << "/" << fa.name;
      EXPECT_EQ(fa.components, fb.components) << pa.name << "/" << fa.name;
      EXPECT_EQ(fa.count, fb.count) << pa.name << "/" << fa.name;
      EXPECT_EQ(fa.bytes, fb.bytes) << pa.name << "/" << fa.name;
    }
  }
}

// ---- a tiny XML parser: enough to prove the index well-formed and walk it ----

struct Node {
  std::string name, text;
  std::map<std::string, std::string> attrs;
  std::vector<Node> children;
  std::vector<const Node*> all(const std::string& n) const {
    std::vector<const Node*> out;
    for (const Node& c : children)
      if (c.name == n)
        out.push_back(&c);
    return out;
  }
};

struct XmlParser {
  const std::string& s;
  std::size_t i = 0;

  [[noreturn]] void bad(const std::string& why) {
    throw std::runtime_error("malformed XML at " + std::to_string(i) + ": " + why);
  }
  void skip_space() {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i])))
      ++i;
  }
  std::string name() {
    const std::size_t b = i;
    while (i < s.size() && (std::isalnum(static_cast<unsigned char>(s[i])) || s[i] == '_' ||
                            s[i] == ':' || s[i] == '-' || s[i] == '.'))
      ++i;
    if (i == b)
      bad("expected a name");
    return s.substr(b, i - b);
  }
  void expect(char c) {
    if (i >= s.size() || s[i] != c)
      bad(std::string("expected '") + c + "'");
    ++i;
  }
  Node element() {
    expect('<');
    Node n;
    n.name = name();
    for (skip_space(); i < s.size() && s[i] != '>' && s[i] != '/'; skip_space()) {
      const std::string key = name();
      expect('=');
      expect('"');
      const std::size_t end = s.find('"', i);
      if (end == std::string::npos || s.find('<', i) < end)
        bad("unterminated attribute");
      if (!n.attrs.emplace(key, s.substr(i, end - i)).second)
        bad("duplicate attribute");
      i = end + 1;
    }
    if (i < s.size() && s[i] == '/') {
      ++i;
      expect('>');
      return n;
    }
    expect('>');
    while (true) {
      const std::size_t lt = s.find('<', i);
      if (lt == std::string::npos)
        bad("unclosed <" + n.name + ">");
      n.text += s.substr(i, lt - i);
      i = lt;
      if (s.compare(i, 2, "</") == 0)
        break;
      n.children.push_back(element());
    }
    i += 2;
    if (name() != n.name)
      bad("mismatched </...> for <" + n.name + ">");
    skip_space();
    expect('>');
    return n;
  }
  Node document() {
    skip_space();
    if (s.compare(i, 5, "<?xml") == 0)
      i = s.find("?>", i) + 2;
    skip_space();
    Node root = element();
    skip_space();
    if (i != s.size())
      bad("content after the root element");
    return root;
  }
};

Node parse_xml_file(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  return XmlParser{text}.document();
}

/// The frames of snapshots.xmf: the spatial collections under the temporal one.
std::vector<const Node*> xdmf_frames(const Node& root) {
  EXPECT_EQ(root.name, "Xdmf");
  const auto domains = root.all("Domain");
  if (domains.size() != 1)
    return {};
  const auto series = domains[0]->all("Grid");
  if (series.size() != 1)
    return {};
  EXPECT_EQ(series[0]->attrs.at("CollectionType"), "Temporal");
  return series[0]->all("Grid");
}

double frame_time(const Node& frame) {
  return std::stod(frame.all("Time").at(0)->attrs.at("Value"));
}

/// Every DataItem names a dataset that exists in its file, with the declared dimensions.
void expect_data_items_exist(const fs::path& dir, const Node& n, int& checked) {
  if (n.name == "DataItem") {
    const std::string ref = n.text;
    const auto colon = ref.find(':');
    ASSERT_NE(colon, std::string::npos) << ref;
    const fs::path file = dir / ref.substr(0, colon);
    const std::string dataset = ref.substr(colon + 1);
    kf::io::h5::File f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
    ASSERT_TRUE(f.valid()) << file;
    const auto slash = dataset.find('/', 1);
    ASSERT_GT(H5Lexists(f, dataset.substr(0, slash).c_str(), H5P_DEFAULT), 0) << ref;
    ASSERT_GT(H5Lexists(f, dataset.c_str(), H5P_DEFAULT), 0) << ref;
    kf::io::h5::Dataset d(H5Dopen2(f, dataset.c_str(), H5P_DEFAULT));
    kf::io::h5::Space space(H5Dget_space(d));
    hsize_t dims[2] = {0, 0};
    const int rank = H5Sget_simple_extent_dims(space, dims, nullptr);
    std::string expected = std::to_string(dims[0]);
    if (rank == 2)
      expected += " " + std::to_string(dims[1]);
    EXPECT_EQ(n.attrs.at("Dimensions"), expected) << ref;
    ++checked;
  }
  for (const Node& c : n.children)
    expect_data_items_exist(dir, c, checked);
}

} // namespace

TEST(Snapshot, RoundTripIsByteExact) {
  const auto dir = kf::test::scratch_dir("snapshot_roundtrip");
  SnapshotWriter writer(MPI_COMM_WORLD, (dir / "out").string());
  const Frame f = sample_frame(3, 0.125);
  const std::string path = writer.write(f);
  EXPECT_EQ(path, (dir / "out" / "frame_000003.h5").string());
  expect_same(f, read_snapshot(MPI_COMM_WORLD, path));
  expect_same(f, read_snapshot_share(MPI_COMM_WORLD, path)); // one rank: its share is everything
}

TEST(Snapshot, EmptyPhaseRoundTrips) {
  const auto dir = kf::test::scratch_dir("snapshot_empty");
  Frame f = sample_frame(0, 0);
  const Frame back = read_snapshot(MPI_COMM_WORLD, SnapshotWriter(MPI_COMM_WORLD, dir).write(f));
  const Phase* knit = back.find("knit");
  ASSERT_NE(knit, nullptr);
  ASSERT_EQ(knit->fields.size(), 2u);
  EXPECT_EQ(knit->fields[0].count, 0u);
  EXPECT_EQ(knit->fields[0].components, 3);
  EXPECT_EQ(knit->fields[1].type, DType::U64);
}

TEST(Snapshot, RootAttributesAreWritten) {
  const auto dir = kf::test::scratch_dir("snapshot_attrs");
  const std::string path = SnapshotWriter(MPI_COMM_WORLD, dir).write(sample_frame(2, 1.5));
  kf::io::h5::File f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  EXPECT_EQ(h5::read_string(f, "units", path), "SI");
  EXPECT_EQ(h5::read_string(f, "knitflow_version", path), "0.1.0");
  EXPECT_EQ(h5::read_uint64(f, "frame", path), 2u);
  kf::io::h5::Group fluid(H5Gopen2(f, "fluid", H5P_DEFAULT));
  EXPECT_EQ(h5::read_uint64(fluid, "count", path), 4u);
}

TEST(Snapshot, LongSceneTextRoundTrips) {
  // Longer than HDF5's 64 KiB limit for compactly stored attributes.
  const auto dir = kf::test::scratch_dir("snapshot_long_scene");
  Frame f = sample_frame(1, 0.5);
  f.scene_text = std::string(200000, 'x') + "\nend";
  expect_same(f, read_snapshot(MPI_COMM_WORLD, SnapshotWriter(MPI_COMM_WORLD, dir).write(f)));
}

TEST(Snapshot, WriteIsAtomic) {
  const auto dir = kf::test::scratch_dir("snapshot_atomic");
  const std::string path = SnapshotWriter(MPI_COMM_WORLD, dir).write(sample_frame(5, 1));
  EXPECT_TRUE(fs::exists(path));
  EXPECT_FALSE(fs::exists(path + ".tmp"));
  EXPECT_TRUE(fs::exists(dir / "snapshots.xmf"));
  EXPECT_FALSE(fs::exists(dir / "snapshots.xmf.tmp"));
}

TEST(Snapshot, XdmfIndexesEveryFrame) {
  const auto dir = kf::test::scratch_dir("snapshot_xdmf");
  SnapshotWriter writer(MPI_COMM_WORLD, dir);
  writer.write(sample_frame(0, 0.0));
  writer.write(sample_frame(1, 0.25));
  const Node root = parse_xml_file(dir / "snapshots.xmf");
  const auto frames = xdmf_frames(root);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frame_time(*frames[0]), 0.0);
  EXPECT_EQ(frame_time(*frames[1]), 0.25);
  for (const Node* frame : frames) {
    const auto grids = frame->all("Grid");
    ASSERT_EQ(grids.size(), 2u); // fluid and boundary; the empty knit phase is left out
    EXPECT_EQ(grids[0]->attrs.at("Name"), "fluid");
    EXPECT_EQ(grids[0]->all("Topology").at(0)->attrs.at("NumberOfElements"), "4");
    EXPECT_EQ(grids[0]->all("Attribute").size(), 3u); // density, id, flags
    EXPECT_EQ(grids[1]->all("Attribute").at(1)->attrs.at("AttributeType"), "Vector");
  }
  int checked = 0;
  expect_data_items_exist(dir, root, checked);
  EXPECT_EQ(checked, 2 * (4 + 3));
}

TEST(Snapshot, RestartAtLowerIndexDropsLaterFrames) {
  const auto dir = kf::test::scratch_dir("snapshot_restart");
  {
    SnapshotWriter first_run(MPI_COMM_WORLD, dir);
    for (std::uint64_t i = 0; i < 4; ++i)
      first_run.write(sample_frame(i, 0.1 * double(i)));
  }
  SnapshotWriter restarted(MPI_COMM_WORLD, dir);
  restarted.write(sample_frame(2, 0.2 + 1e-9)); // the restarted run diverges from frame 2 on
  const Node root = parse_xml_file(dir / "snapshots.xmf");
  const auto frames = xdmf_frames(root);
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frame_time(*frames[0]), 0.0);
  EXPECT_EQ(frame_time(*frames[1]), 0.1);
  EXPECT_EQ(frame_time(*frames[2]), 0.2 + 1e-9);
}

TEST(Snapshot, MissingFileThrowsNamingThePath) {
  const auto dir = kf::test::scratch_dir("snapshot_missing");
  const std::string path = (dir / "frame_000042.h5").string();
  try {
    read_snapshot(MPI_COMM_WORLD, path);
    FAIL() << "no error for a missing snapshot";
  } catch (const kf::Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(Snapshot, CorruptFileThrowsNamingThePath) {
  const auto dir = kf::test::scratch_dir("snapshot_corrupt");
  const std::string path = (dir / "frame_000001.h5").string();
  std::ofstream(path) << "not an HDF5 file";
  try {
    read_snapshot(MPI_COMM_WORLD, path);
    FAIL() << "no error for a corrupt snapshot";
  } catch (const kf::Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  // The writer does not index it either.
  SnapshotWriter(MPI_COMM_WORLD, dir).write(sample_frame(2, 0));
  EXPECT_EQ(xdmf_frames(parse_xml_file(dir / "snapshots.xmf")).size(), 1u);
}

TEST(Snapshot, InvalidFrameIsRejected) {
  const auto dir = kf::test::scratch_dir("snapshot_invalid");
  SnapshotWriter writer(MPI_COMM_WORLD, dir);
  Frame ragged = sample_frame(0, 0);
  ragged.phases[0].fields[1] = Field::from("density", std::vector<double>{1, 2}, 1);
  EXPECT_THROW(writer.write(ragged), kf::Error);
  Frame reserved = sample_frame(0, 0);
  reserved.scalars.emplace_back("time", 1.0);
  EXPECT_THROW(writer.write(reserved), kf::Error);
}

// A snapshot of another format (or none named) is refused in one line naming the file and both
// versions, before any of its datasets is read as if it were this format.
TEST(Snapshot, AnotherFormatIsRefusedByName) {
  const auto dir = kf::test::scratch_dir("snapshot_version");
  const std::string path = SnapshotWriter(MPI_COMM_WORLD, dir).write(sample_frame(1, 0));
  EXPECT_NO_THROW(read_snapshot(MPI_COMM_WORLD, path));
  const auto rewrite = [&](const char* version) {
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    ASSERT_GE(H5Adelete(f, "knitflow_version"), 0);
    if (version)
      kf::io::h5::write_attribute(f, "knitflow_version", std::string(version), path);
    H5Fclose(f);
  };
  const auto message = [&] {
    try {
      read_snapshot(MPI_COMM_WORLD, path);
    } catch (const kf::Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  rewrite("0.1.7"); // a patch level reads
  EXPECT_NO_THROW(read_snapshot(MPI_COMM_WORLD, path));
  rewrite("0.2.0");
  std::string m = message();
  EXPECT_EQ(m, path + ": a snapshot of format 0.2.0 (knitflow_version); this knitflow reads "
                      "format 0.1.x");
  rewrite(nullptr);
  m = message();
  EXPECT_EQ(m.rfind(path + ": not a knitflow snapshot of a known format", 0), 0u) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
}
