#include "io/SnapshotReader.hpp"

#include "io/SnapshotHdf5.hpp"

#include <algorithm>
#include <filesystem>

namespace kf::io {
namespace {

/// Opens path read-only: through MPI-IO on comm, or with the default POSIX driver when comm is
/// MPI_COMM_NULL (one process).
h5::File open_file(MPI_Comm comm, const std::string& path) {
  h5::silence_errors();
  if (!std::filesystem::is_regular_file(path))
    throw Error(path + ": snapshot file not found");
  h5::Plist fapl(h5::check(H5Pcreate(H5P_FILE_ACCESS), path, "creating file access properties"));
  if (comm != MPI_COMM_NULL) {
    h5::check(H5Pset_fapl_mpio(fapl, comm, MPI_INFO_NULL), path, "selecting MPI-IO");
    // Rank 0 reads the metadata and broadcasts it, rather than every rank asking the file system.
    h5::check(H5Pset_all_coll_metadata_ops(fapl, true), path, "asking for collective metadata");
  } else {
    // Finished snapshots are never written again, and locks fail on some NFS/Lustre mounts.
    h5::check(H5Pset_file_locking(fapl, false, true), path, "disabling file locking");
  }
  return h5::File(
      h5::check(H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl), path, "opening the snapshot"));
}

template <typename Info>
herr_t collect_name(hid_t, const char* name, const Info*, void* names) {
  static_cast<std::vector<std::string>*>(names)->emplace_back(name);
  return 0;
}

/// Names from an HDF5 iteration, in creation order where the file tracks it (ours does, so a
/// round trip keeps the order of phases, fields and scalars), else alphabetically.
template <typename Iterate>
std::vector<std::string> names_in_order(Iterate iterate, const std::string& path,
                                        const std::string& what) {
  std::vector<std::string> names;
  for (H5_index_t order : {H5_INDEX_CRT_ORDER, H5_INDEX_NAME}) {
    names.clear();
    if (iterate(order, &names) >= 0)
      return names;
  }
  h5::fail(path, "listing " + what);
}

std::vector<std::string> link_names(hid_t group, const std::string& path, const std::string& what) {
  return names_in_order(
      [&](H5_index_t order, std::vector<std::string>* names) {
        return H5Literate(group, order, H5_ITER_INC, nullptr, collect_name<H5L_info_t>, names);
      },
      path, what);
}

std::vector<std::string> attribute_names(hid_t obj, const std::string& path) {
  return names_in_order(
      [&](H5_index_t order, std::vector<std::string>* names) {
        return H5Aiterate2(obj, order, H5_ITER_INC, nullptr, collect_name<H5A_info_t>, names);
      },
      path, "the attributes");
}

/// Opens loc/name when it is an object of `kind` (group or dataset); an invalid handle otherwise.
h5::Object open_if(hid_t loc, const std::string& name, H5I_type_t kind, const std::string& path) {
  h5::Object obj(h5::check(H5Oopen(loc, name.c_str(), H5P_DEFAULT), path, "opening " + name));
  return H5Iget_type(obj) == kind ? std::move(obj) : h5::Object();
}

FieldLayout field_layout(hid_t dataset, const PhaseLayout& phase, const std::string& name,
                         const std::string& path) {
  const std::string what = "dataset /" + phase.name + "/" + name;
  h5::Type type(h5::check(H5Dget_type(dataset), path, "reading the type of " + what));
  h5::Space space(h5::check(H5Dget_space(dataset), path, "reading the shape of " + what));
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 1 || rank > 2)
    throw Error(path + ": " + what + " is not a [rows] or [rows, components] array");
  hsize_t dims[2] = {0, 1};
  h5::check(H5Sget_simple_extent_dims(space, dims, nullptr), path, "reading the shape of " + what);
  if (dims[0] != phase.count)
    throw Error(path + ": " + what + " has " + std::to_string(dims[0]) +
                " rows but the phase count is " + std::to_string(phase.count));
  return {name, h5::dtype_of(type, path, what), int(dims[1])};
}

/// Every group in the root is a phase; every dataset in it a field.
std::vector<PhaseLayout> read_layout(hid_t file, const std::string& path) {
  std::vector<PhaseLayout> phases;
  for (const auto& name : link_names(file, path, "the phases")) {
    h5::Object group = open_if(file, name, H5I_GROUP, path);
    if (!group.valid())
      continue;
    PhaseLayout phase{name, h5::read_uint64(group, "count", path), {}};
    for (const auto& field : link_names(group, path, "the fields of /" + name)) {
      h5::Object dataset = open_if(group, field, H5I_DATASET, path);
      if (dataset.valid())
        phase.fields.push_back(field_layout(dataset, phase, field, path));
    }
    phases.push_back(std::move(phase));
  }
  return phases;
}

bool is_scalar_float(hid_t obj, const std::string& name, const std::string& path) {
  h5::Attr attr(h5::check(H5Aopen(obj, name.c_str(), H5P_DEFAULT), path, "opening " + name));
  h5::Type type(h5::check(H5Aget_type(attr), path, "reading the type of " + name));
  h5::Space space(h5::check(H5Aget_space(attr), path, "reading the shape of " + name));
  return H5Tget_class(type) == H5T_FLOAT && H5Sget_simple_extent_npoints(space) == 1;
}

void read_header(hid_t file, const std::string& path, Frame& f) {
  h5::check_format_version(file, path);
  f.time = h5::read_double(file, "time", path);
  f.step = h5::read_uint64(file, "step", path);
  f.index = h5::read_uint64(file, "frame", path);
  f.precision = h5::read_string(file, "precision", path);
  f.scene_text = h5::read_string(file, "scene", path);
  if (H5Aexists(file, "scene_dir") > 0)
    f.scene_dir = h5::read_string(file, "scene_dir", path);
  const auto& reserved = h5::reserved_attributes();
  for (const auto& name : attribute_names(file, path))
    if (std::find(reserved.begin(), reserved.end(), name) == reserved.end() &&
        is_scalar_float(file, name, path))
      f.scalars.emplace_back(name, h5::read_double(file, name, path));
}

Field read_field(hid_t group, const std::string& phase, const FieldLayout& layout,
                 std::uint64_t first, std::uint64_t count, hid_t dxpl, const std::string& path) {
  const std::string what = "dataset /" + phase + "/" + layout.name;
  Field field{layout.name, layout.type, layout.components, count, {}};
  field.bytes.resize(count * layout.components * dtype_size(layout.type));
  h5::Dataset dataset(
      h5::check(H5Dopen2(group, layout.name.c_str(), H5P_DEFAULT), path, "opening " + what));
  h5::Space file_space(h5::check(H5Dget_space(dataset), path, "reading the shape of " + what));
  if (H5Sget_simple_extent_npoints(file_space) == 0)
    return field; // empty on every rank
  h5::select_rows(file_space, first, count, path, what);
  h5::Space memory = h5::memory_space(count, layout.components, path, what);
  h5::check(H5Dread(dataset, h5::native_type(layout.type), memory, file_space, dxpl,
                    h5::buffer(field.bytes)),
            path, "reading " + what);
  return field;
}

struct Rows {
  std::uint64_t first = 0, count = 0;
};

/// Rank r's contiguous share of n rows split as evenly as possible over p ranks.
Rows share_of(std::uint64_t n, int r, int p) {
  const std::uint64_t first = n * r / p, end = n * (r + 1) / p;
  return {first, end - first};
}

/// `share(phase)`: whether a phase is read as this rank's share or whole.
template <typename Share>
Frame read_frame(MPI_Comm comm, const std::string& path, Share&& share) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  h5::File file = open_file(comm, path);
  Frame f;
  read_header(file, path, f);
  h5::Plist dxpl = h5::collective_transfer(path);
  for (const PhaseLayout& layout : read_layout(file, path)) {
    const bool shared = share(layout.name);
    const Rows rows = shared ? share_of(layout.count, rank, size) : Rows{0, layout.count};
    if (shared) {
      f.shared_phases.push_back(layout.name);
      f.share_ranks = size;
    }
    h5::Group group(h5::check(H5Gopen2(file, layout.name.c_str(), H5P_DEFAULT), path,
                              "opening group /" + layout.name));
    Phase phase{layout.name, {}};
    for (const FieldLayout& field : layout.fields)
      phase.fields.push_back(
          read_field(group, layout.name, field, rows.first, rows.count, dxpl, path));
    f.phases.push_back(std::move(phase));
  }
  return f;
}

} // namespace

Frame read_snapshot(MPI_Comm comm, const std::string& path) {
  return read_frame(comm, path, [](const std::string&) { return false; });
}

Frame read_snapshot_share(MPI_Comm comm, const std::string& path) {
  return read_frame(comm, path, [](const std::string&) { return true; });
}

Frame read_snapshot_shares(MPI_Comm comm, const std::string& path,
                           const std::vector<std::string>& shared) {
  return read_frame(comm, path, [&](const std::string& phase) {
    return std::find(shared.begin(), shared.end(), phase) != shared.end();
  });
}

SnapshotInfo read_snapshot_info(const std::string& path) {
  h5::File file = open_file(MPI_COMM_NULL, path);
  SnapshotInfo info;
  info.file = std::filesystem::path(path).filename().string();
  info.index = h5::read_uint64(file, "frame", path);
  info.time = h5::read_double(file, "time", path);
  info.phases = read_layout(file, path);
  return info;
}

} // namespace kf::io
