#include "io/SnapshotWriter.hpp"

#include "io/SnapshotHdf5.hpp"
#include "io/SnapshotReader.hpp"
#include "io/Xdmf.hpp"

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <regex>
#include <set>

namespace kf::io {

std::string snapshot_file_name(std::uint64_t index) {
  char name[40];
  std::snprintf(name, sizeof name, "frame_%06llu.h5", static_cast<unsigned long long>(index));
  return name;
}

namespace {

/// Runs fn on rank 0 only and makes its failure every rank's failure, so that no rank goes on to
/// wait forever in a later collective call.
void on_rank0(MPI_Comm comm, const std::string& what, const std::function<void()>& fn) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  std::string error;
  if (rank == 0) {
    try {
      fn();
    } catch (const Error& e) {
      error = e.what();
    } catch (const std::exception& e) {
      error = what + " failed: " + e.what();
    }
  }
  int length = int(error.size());
  MPI_Bcast(&length, 1, MPI_INT, 0, comm);
  if (length == 0)
    return;
  error.resize(length);
  MPI_Bcast(error.data(), length, MPI_CHAR, 0, comm);
  throw Error(error);
}

std::uint64_t rows_of(const Phase& p) {
  return p.fields.empty() ? 0 : p.fields.front().count;
}

bool valid_name(const std::string& s) {
  return !s.empty() && s != "." && s.find('/') == std::string::npos;
}

/// What is wrong with this rank's frame on its own (empty when nothing is).
std::string local_problem(const Frame& f) {
  const auto& reserved = h5::reserved_attributes();
  std::set<std::string> scalars, phases;
  for (const auto& [name, value] : f.scalars)
    if (std::find(reserved.begin(), reserved.end(), name) != reserved.end() ||
        !scalars.insert(name).second)
      return "scalar '" + name + "' is reserved or given twice";
  for (const Phase& p : f.phases) {
    if (!valid_name(p.name) || !phases.insert(p.name).second)
      return "phase name '" + p.name + "' is empty, contains '/' or is given twice";
    std::set<std::string> fields;
    for (const Field& fl : p.fields) {
      const std::string where = "field /" + p.name + "/" + fl.name;
      if (!valid_name(fl.name) || !fields.insert(fl.name).second)
        return where + ": the name is empty, contains '/' or is given twice";
      if (fl.components < 1 || fl.count != rows_of(p))
        return where + ": " + std::to_string(fl.count) + " rows of " +
               std::to_string(fl.components) + " components, but the phase has " +
               std::to_string(rows_of(p)) + " rows";
      if (fl.bytes.size() != fl.count * fl.components * dtype_size(fl.type))
        return where + ": holds " + std::to_string(fl.bytes.size()) + " bytes, not rows x " +
               "components x element size";
    }
  }
  return {};
}

/// Phases and fields as "fluid{position:0x3,...} ..." (type as the DType number).
std::string describe_layout(const Frame& f) {
  std::string s;
  for (const Phase& p : f.phases) {
    s += p.name + "{";
    for (const Field& fl : p.fields)
      s += fl.name + ":" + std::to_string(int(fl.type)) + "x" + std::to_string(fl.components) + ",";
    s += "} ";
  }
  return s;
}

template <typename T>
std::string bits_of(const T& v) {
  std::string s(sizeof v, '\0');
  std::memcpy(s.data(), &v, sizeof v);
  return s;
}

/// FNV-1a over everything all ranks must agree on: attributes (which HDF5 writes collectively)
/// and the phase/field layout.
std::uint64_t header_digest(const Frame& f) {
  std::string s = bits_of(f.time) + bits_of(f.step) + bits_of(f.index) + f.precision + '\0' +
                  f.scene_text + '\0' + f.scene_dir + '\0' + describe_layout(f);
  for (const auto& [name, value] : f.scalars)
    s += name + '\0' + bits_of(value);
  std::uint64_t h = 14695981039346656037ull;
  for (unsigned char c : s)
    h = (h ^ c) * 1099511628211ull;
  return h;
}

/// Collective: throws the same kind of error on every rank when any rank's frame is invalid or
/// the ranks disagree on the header or layout (one small allreduce).
void check_frames_agree(MPI_Comm comm, const Frame& f, const std::string& path) {
  const std::string problem = local_problem(f);
  const std::uint64_t h = header_digest(f);
  std::uint64_t mine[3] = {h, ~h, problem.empty() ? 0u : 1u}, max[3] = {0, 0, 0};
  MPI_Allreduce(mine, max, 3, MPI_UINT64_T, MPI_MAX, comm);
  if (!problem.empty())
    throw Error(path + ": " + problem);
  if (max[2] != 0)
    throw Error(path + ": another rank's frame is invalid (see its message)");
  if (max[0] != h || max[1] != ~h) // max(h) != h or min(h) != h
    throw Error(path + ": ranks disagree on the frame attributes or phases/fields; this rank has " +
                describe_layout(f));
}

/// Per phase: this rank's first global row (exclusive scan of counts) and the global row count.
struct RowOffsets {
  std::vector<std::uint64_t> first, total;
};

RowOffsets row_offsets(MPI_Comm comm, const Frame& f) {
  const int n = int(f.phases.size());
  std::vector<std::uint64_t> mine(n);
  std::transform(f.phases.begin(), f.phases.end(), mine.begin(), rows_of);
  RowOffsets rows{std::vector<std::uint64_t>(n, 0), std::vector<std::uint64_t>(n, 0)};
  MPI_Exscan(mine.data(), rows.first.data(), n, MPI_UINT64_T, MPI_SUM, comm);
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  if (rank == 0)
    std::fill(rows.first.begin(), rows.first.end(), 0); // Exscan leaves it undefined
  MPI_Allreduce(mine.data(), rows.total.data(), n, MPI_UINT64_T, MPI_SUM, comm);
  return rows;
}

/// Creation properties that track creation order, so readers list phases, fields and scalars in
/// the order they were written.
h5::Plist ordered(hid_t cls, const std::string& path) {
  h5::Plist plist(h5::check(H5Pcreate(cls), path, "creating creation properties"));
  const unsigned flags = H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED;
  h5::check(H5Pset_link_creation_order(plist, flags), path, "tracking link order");
  h5::check(H5Pset_attr_creation_order(plist, flags), path, "tracking attribute order");
  return plist;
}

h5::File create_file(MPI_Comm comm, const std::string& path) {
  h5::Plist fapl(h5::check(H5Pcreate(H5P_FILE_ACCESS), path, "creating file access properties"));
  h5::check(H5Pset_fapl_mpio(fapl, comm, MPI_INFO_NULL), path, "selecting MPI-IO");
  // Collective metadata I/O: rank 0 touches the file for metadata instead of every rank.
  h5::check(H5Pset_coll_metadata_write(fapl, true), path, "asking for collective metadata");
  h5::check(H5Pset_all_coll_metadata_ops(fapl, true), path, "asking for collective metadata");
  // The 1.8 object format stores attributes over 64 KiB (long scene texts) and creation order.
  h5::check(H5Pset_libver_bounds(fapl, H5F_LIBVER_V18, H5F_LIBVER_V18), path,
            "choosing the file format");
  h5::Plist fcpl = ordered(H5P_FILE_CREATE, path);
  return h5::File(
      h5::check(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, fcpl, fapl), path, "creating the snapshot"));
}

void write_header(hid_t file, const Frame& f, const std::string& path) {
  h5::write_attribute(file, "time", f.time, path);
  h5::write_attribute(file, "step", f.step, path);
  h5::write_attribute(file, "frame", f.index, path);
  h5::write_attribute(file, "precision", f.precision, path);
  h5::write_attribute(file, "scene", f.scene_text, path);
  if (!f.scene_dir.empty())
    h5::write_attribute(file, "scene_dir", f.scene_dir, path);
  h5::write_attribute(file, "units", std::string("SI"), path);
  h5::write_attribute(file, "knitflow_version", std::string(h5::kFormatVersion), path);
  for (const auto& [name, value] : f.scalars)
    h5::write_attribute(file, name, value, path);
}

/// Collective: creates /phase/field with `total` rows and writes this rank's rows from `first`.
void write_field(hid_t group, const std::string& phase, const Field& field, std::uint64_t first,
                 std::uint64_t total, hid_t dxpl, const std::string& path) {
  const std::string what = "dataset /" + phase + "/" + field.name;
  const auto dims = h5::row_dims(total, field.components);
  h5::Space file_space(h5::check(H5Screate_simple(int(dims.size()), dims.data(), nullptr), path,
                                 "creating the shape of " + what));
  h5::Plist dcpl(h5::check(H5Pcreate(H5P_DATASET_CREATE), path, "creating " + what));
  // Every row gets written, so skip writing fill values first.
  h5::check(H5Pset_fill_time(dcpl, H5D_FILL_TIME_NEVER), path, "creating " + what);
  const hid_t type = h5::native_type(field.type);
  h5::Dataset dataset(h5::check(
      H5Dcreate2(group, field.name.c_str(), type, file_space, H5P_DEFAULT, dcpl, H5P_DEFAULT), path,
      "creating " + what));
  if (total == 0)
    return; // nothing to transfer on any rank
  h5::select_rows(file_space, first, field.count, path, what);
  h5::Space memory = h5::memory_space(field.count, field.components, path, what);
  h5::check(H5Dwrite(dataset, type, memory, file_space, dxpl, h5::buffer(field.bytes)), path,
            "writing " + what);
}

void write_phase(hid_t file, const Phase& phase, std::uint64_t first, std::uint64_t total,
                 hid_t dxpl, const std::string& path) {
  h5::Plist gcpl = ordered(H5P_GROUP_CREATE, path);
  h5::Group group(h5::check(H5Gcreate2(file, phase.name.c_str(), H5P_DEFAULT, gcpl, H5P_DEFAULT),
                            path, "creating group /" + phase.name));
  h5::write_attribute(group, "count", total, path);
  for (const Field& field : phase.fields)
    write_field(group, phase.name, field, first, total, dxpl, path);
}

/// Collective: the whole file at `path`, closed (flushed) before returning.
void write_file(MPI_Comm comm, const std::string& path, const Frame& f, const RowOffsets& rows) {
  h5::File file = create_file(comm, path);
  write_header(file, f, path);
  h5::Plist dxpl = h5::collective_transfer(path);
  for (std::size_t i = 0; i < f.phases.size(); ++i)
    write_phase(file, f.phases[i], rows.first[i], rows.total[i], dxpl, path);
  h5::check(file.close(), path, "closing the snapshot");
}

SnapshotInfo info_of(const Frame& f, const RowOffsets& rows, const std::string& file) {
  SnapshotInfo info{file, f.index, f.time, {}};
  for (std::size_t i = 0; i < f.phases.size(); ++i) {
    PhaseLayout phase{f.phases[i].name, rows.total[i], {}};
    for (const Field& fl : f.phases[i].fields)
      phase.fields.push_back({fl.name, fl.type, fl.components});
    info.phases.push_back(std::move(phase));
  }
  return info;
}

/// The readable frame_*.h5 files in dir by index (unreadable leftovers are not indexed).
std::map<std::uint64_t, SnapshotInfo> scan_snapshots(const std::string& dir) {
  static const std::regex pattern(R"(frame_\d+\.h5)");
  std::map<std::uint64_t, SnapshotInfo> found;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (!std::regex_match(entry.path().filename().string(), pattern))
      continue;
    try {
      SnapshotInfo info = read_snapshot_info(entry.path().string());
      found[info.index] = std::move(info);
    } catch (const Error&) {
    }
  }
  return found;
}

std::vector<SnapshotInfo> values(const std::map<std::uint64_t, SnapshotInfo>& index) {
  std::vector<SnapshotInfo> v;
  for (const auto& [key, info] : index)
    v.push_back(info);
  return v;
}

} // namespace

SnapshotWriter::SnapshotWriter(MPI_Comm comm, std::string dir) : comm_(comm), dir_(std::move(dir)) {
  h5::silence_errors();
  on_rank0(comm_, dir_ + ": preparing the snapshot directory", [&] {
    std::filesystem::create_directories(dir_);
    index_ = scan_snapshots(dir_);
  });
}

namespace {

/// The kill-and-resume tests' hook (KF_KILL_PUBLISHING=N): the N-th file this process
/// publishes whose name holds "checkpoint" ends the process with SIGKILL once its temporary file
/// is written and before the rename: a job killed in the middle of a checkpoint's write.
void kill_if_asked(const std::string& path) {
  static const char* at = std::getenv("KF_KILL_PUBLISHING");
  static long count = 0;
  if (!at || path.find("checkpoint") == std::string::npos)
    return;
  if (++count == std::atol(at))
    std::raise(SIGKILL);
}

/// publish_snapshot, its row offsets returned.
RowOffsets publish(MPI_Comm comm, const std::string& path, const Frame& f) {
  const std::string tmp = path + ".tmp";
  h5::silence_errors();
  check_frames_agree(comm, f, path);
  const RowOffsets rows = row_offsets(comm, f);
  write_file(comm, tmp, f, rows);
  kill_if_asked(path);
  MPI_Barrier(comm); // every rank has closed the file before it gets its final name
  on_rank0(comm, path + ": publishing the snapshot", [&] { std::filesystem::rename(tmp, path); });
  return rows;
}

} // namespace

std::string publish_snapshot(MPI_Comm comm, const std::string& path, const Frame& f) {
  publish(comm, path, f);
  return path;
}

std::string SnapshotWriter::write(const Frame& f) {
  const std::string name = snapshot_file_name(f.index);
  const std::string path = dir_ + "/" + name;
  const RowOffsets rows = publish(comm_, path, f);
  on_rank0(comm_, path + ": indexing the snapshot", [&] {
    index_.erase(index_.upper_bound(f.index), index_.end());
    index_[f.index] = info_of(f, rows, name);
    write_xdmf(dir_ + "/snapshots.xmf", values(index_));
  });
  return path;
}

} // namespace kf::io
