#pragma once
// Internal helpers shared by the snapshot writer and reader: RAII ownership of HDF5 handles,
// return-value checks that become kf::Error, element-type mapping and row selections.
// Not part of the public io API.
#include "core/Error.hpp"
#include "io/Frame.hpp"

#include <hdf5.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace kf::io::h5 {

/// Owns one HDF5 identifier and closes it with `Close` (errors on close in a destructor are
/// ignored; use close() where the result matters, e.g. the final flush of a file).
template <herr_t (*Close)(hid_t)>
class Handle {
public:
  Handle() = default;
  explicit Handle(hid_t id) : id_(id) {}
  Handle(Handle&& o) noexcept : id_(std::exchange(o.id_, H5I_INVALID_HID)) {}
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, H5I_INVALID_HID);
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() { reset(); }

  operator hid_t() const { return id_; }
  bool valid() const { return id_ >= 0; }
  /// Closes now and returns HDF5's result.
  herr_t close() { return id_ >= 0 ? Close(std::exchange(id_, H5I_INVALID_HID)) : 0; }
  void reset() { (void)close(); }

private:
  hid_t id_ = H5I_INVALID_HID;
};

using File = Handle<H5Fclose>;
using Group = Handle<H5Gclose>;
using Dataset = Handle<H5Dclose>;
using Space = Handle<H5Sclose>;
using Attr = Handle<H5Aclose>;
using Type = Handle<H5Tclose>;
using Plist = Handle<H5Pclose>;
using Object = Handle<H5Oclose>;

/// Turns off HDF5's printing of its error stack; failures are reported through kf::Error.
void silence_errors();

/// Throws kf::Error("<path>: <what> failed (<innermost HDF5 message>)").
[[noreturn]] void fail(const std::string& path, const std::string& what);

/// Returns r, or throws through fail() when HDF5 reported an error (negative result).
template <typename R>
R check(R r, const std::string& path, const std::string& what) {
  if (r < 0)
    fail(path, what);
  return r;
}

/// The native HDF5 memory type of a field element type (a library constant: not to be closed).
hid_t native_type(DType t);
/// The DType of a dataset's element type; throws for types a Frame cannot hold.
DType dtype_of(hid_t type, const std::string& path, const std::string& what);

/// Dimensions of a per-particle dataset: [rows] for one component, else [rows, components].
std::vector<hsize_t> row_dims(std::uint64_t rows, int components);

/// Selects rows [first, first + count) of a [rows] or [rows, components] space (none if count=0).
void select_rows(hid_t space, std::uint64_t first, std::uint64_t count, const std::string& path,
                 const std::string& what);

/// A memory space holding `count` rows (a one-row space with nothing selected when count = 0, so a
/// rank without rows can still join a collective transfer).
Space memory_space(std::uint64_t count, int components, const std::string& path,
                   const std::string& what);

/// A buffer address for H5Dread/H5Dwrite: HDF5 rejects a null buffer even for an empty selection.
template <typename Bytes>
auto* buffer(Bytes& bytes) {
  static unsigned char dummy = 0;
  return bytes.empty() ? &dummy : bytes.data();
}

/// A transfer property list for collective MPI-IO.
Plist collective_transfer(const std::string& path);

/// Scalar attributes (created on write, read back with type conversion where HDF5 allows it).
void write_attribute(hid_t obj, const std::string& name, double v, const std::string& path);
void write_attribute(hid_t obj, const std::string& name, std::uint64_t v, const std::string& path);
void write_attribute(hid_t obj, const std::string& name, const std::string& v,
                     const std::string& path);
double read_double(hid_t obj, const std::string& name, const std::string& path);
std::uint64_t read_uint64(hid_t obj, const std::string& name, const std::string& path);
std::string read_string(hid_t obj, const std::string& name, const std::string& path);

/// Root attribute names the snapshot itself uses (Frame::scalars must not reuse them).
const std::vector<std::string>& reserved_attributes();

/// The snapshot format this build writes ("major.minor.patch"); a reader takes files of the same
/// major.minor and refuses others by name (their layout may differ).
inline constexpr const char* kFormatVersion = "0.1.0";
/// Throws "PATH: a snapshot of format V (knitflow_version), this knitflow reads 0.1.x" unless
/// the file's version has this build's major.minor (a missing version likewise).
void check_format_version(hid_t file, const std::string& path);

} // namespace kf::io::h5
