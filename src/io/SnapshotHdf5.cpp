#include "io/SnapshotHdf5.hpp"

#include <algorithm>

namespace kf::io::h5 {

void silence_errors() {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

// Keeps the most specific message on HDF5's error stack (the first one walking upward).
static herr_t innermost_message(unsigned n, const H5E_error2_t* err, void* out) {
  if (n == 0 && err->desc)
    *static_cast<std::string*>(out) = err->desc;
  return 0;
}

void fail(const std::string& path, const std::string& what) {
  std::string detail;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, innermost_message, &detail);
  H5Eclear2(H5E_DEFAULT);
  throw Error(path + ": " + what + " failed" + (detail.empty() ? "" : " (" + detail + ")"));
}

hid_t native_type(DType t) {
  switch (t) {
  case DType::F32:
    return H5T_NATIVE_FLOAT;
  case DType::F64:
    return H5T_NATIVE_DOUBLE;
  case DType::U32:
    return H5T_NATIVE_UINT32;
  case DType::U64:
    return H5T_NATIVE_UINT64;
  case DType::I32:
    return H5T_NATIVE_INT32;
  }
  return H5I_INVALID_HID;
}

DType dtype_of(hid_t type, const std::string& path, const std::string& what) {
  const H5T_class_t cls = H5Tget_class(type);
  const std::size_t size = H5Tget_size(type);
  if (cls == H5T_FLOAT && size == 4)
    return DType::F32;
  if (cls == H5T_FLOAT && size == 8)
    return DType::F64;
  if (cls == H5T_INTEGER) {
    const bool is_signed = H5Tget_sign(type) == H5T_SGN_2;
    if (is_signed && size == 4)
      return DType::I32;
    if (!is_signed && size == 4)
      return DType::U32;
    if (!is_signed && size == 8)
      return DType::U64;
  }
  throw Error(path + ": " + what + " has an element type a snapshot cannot hold (class " +
              std::to_string(static_cast<int>(cls)) + ", " + std::to_string(size) + " bytes)");
}

std::vector<hsize_t> row_dims(std::uint64_t rows, int components) {
  if (components == 1)
    return {hsize_t(rows)};
  return {hsize_t(rows), hsize_t(components)};
}

void select_rows(hid_t space, std::uint64_t first, std::uint64_t count, const std::string& path,
                 const std::string& what) {
  if (count == 0) {
    check(H5Sselect_none(space), path, what + ": selecting no rows");
    return;
  }
  std::vector<hsize_t> dims(2, 0);
  const int rank = check(H5Sget_simple_extent_dims(space, dims.data(), nullptr), path, what);
  std::vector<hsize_t> start{first, 0}, block{count, rank == 2 ? dims[1] : 1};
  start.resize(rank);
  block.resize(rank);
  check(H5Sselect_hyperslab(space, H5S_SELECT_SET, start.data(), nullptr, block.data(), nullptr),
        path, what + ": selecting rows");
}

Space memory_space(std::uint64_t count, int components, const std::string& path,
                   const std::string& what) {
  const auto dims = row_dims(count == 0 ? 1 : count, components);
  Space space(check(H5Screate_simple(int(dims.size()), dims.data(), nullptr), path,
                    what + ": creating the memory space"));
  if (count == 0)
    check(H5Sselect_none(space), path, what + ": selecting no rows");
  return space;
}

Plist collective_transfer(const std::string& path) {
  Plist dxpl(check(H5Pcreate(H5P_DATASET_XFER), path, "creating a transfer property list"));
  check(H5Pset_dxpl_mpio(dxpl, H5FD_MPIO_COLLECTIVE), path, "requesting collective MPI-IO");
  return dxpl;
}

void check_format_version(hid_t file, const std::string& path) {
  const auto major_minor = [](const std::string& v) { return v.substr(0, v.rfind('.')); };
  const std::string mine = major_minor(kFormatVersion);
  if (H5Aexists(file, "knitflow_version") <= 0)
    throw Error(path +
                ": not a knitflow snapshot of a known format (no knitflow_version "
                "attribute); this knitflow reads format " +
                mine + ".x");
  const std::string v = read_string(file, "knitflow_version", path);
  if (major_minor(v) != mine)
    throw Error(path + ": a snapshot of format " + v + " (knitflow_version); this knitflow reads " +
                "format " + mine + ".x");
}

const std::vector<std::string>& reserved_attributes() {
  static const std::vector<std::string> names{
      "time", "step", "frame", "precision", "scene", "units", "knitflow_version", "scene_dir"};
  return names;
}

static std::string attr_what(const std::string& verb, const std::string& name) {
  return verb + " attribute '" + name + "'";
}

static void write_scalar(hid_t obj, const std::string& name, hid_t type, const void* value,
                         const std::string& path) {
  Space space(check(H5Screate(H5S_SCALAR), path, attr_what("creating the space of", name)));
  Attr attr(check(H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT), path,
                  attr_what("creating", name)));
  check(H5Awrite(attr, type, value), path, attr_what("writing", name));
}

void write_attribute(hid_t obj, const std::string& name, double v, const std::string& path) {
  write_scalar(obj, name, H5T_NATIVE_DOUBLE, &v, path);
}

void write_attribute(hid_t obj, const std::string& name, std::uint64_t v, const std::string& path) {
  write_scalar(obj, name, H5T_NATIVE_UINT64, &v, path);
}

void write_attribute(hid_t obj, const std::string& name, const std::string& v,
                     const std::string& path) {
  // Fixed-length, NUL-terminated: the simplest string type every HDF5 reader understands.
  Type type(check(H5Tcopy(H5T_C_S1), path, attr_what("typing", name)));
  check(H5Tset_size(type, v.size() + 1), path, attr_what("sizing", name));
  check(H5Tset_strpad(type, H5T_STR_NULLTERM), path, attr_what("typing", name));
  write_scalar(obj, name, type, v.c_str(), path);
}

// Opens an attribute that must hold exactly one value (guards the fixed-size reads below).
static Attr open_scalar(hid_t obj, const std::string& name, const std::string& path) {
  Attr attr(check(H5Aopen(obj, name.c_str(), H5P_DEFAULT), path, attr_what("opening", name)));
  Space space(check(H5Aget_space(attr), path, attr_what("reading the space of", name)));
  if (H5Sget_simple_extent_npoints(space) != 1)
    throw Error(path + ": attribute '" + name + "' is not a single value");
  return attr;
}

template <typename T>
static T read_number(hid_t obj, const std::string& name, hid_t type, const std::string& path) {
  Attr attr = open_scalar(obj, name, path);
  T v{};
  check(H5Aread(attr, type, &v), path, attr_what("reading", name));
  return v;
}

double read_double(hid_t obj, const std::string& name, const std::string& path) {
  return read_number<double>(obj, name, H5T_NATIVE_DOUBLE, path);
}

std::uint64_t read_uint64(hid_t obj, const std::string& name, const std::string& path) {
  return read_number<std::uint64_t>(obj, name, H5T_NATIVE_UINT64, path);
}

std::string read_string(hid_t obj, const std::string& name, const std::string& path) {
  Attr attr = open_scalar(obj, name, path);
  Type type(check(H5Aget_type(attr), path, attr_what("reading the type of", name)));
  if (H5Tget_class(type) != H5T_STRING)
    throw Error(path + ": attribute '" + name + "' is not a string");
  if (H5Tis_variable_str(type) > 0) { // as written by h5py and others
    char* s = nullptr;
    check(H5Aread(attr, type, &s), path, attr_what("reading", name));
    std::string v = s ? s : "";
    H5free_memory(s);
    return v;
  }
  std::string v(H5Tget_size(type), '\0');
  check(H5Aread(attr, type, v.data()), path, attr_what("reading", name));
  v.resize(std::min(v.size(), v.find('\0'))); // up to the terminator
  return v;
}

} // namespace kf::io::h5
