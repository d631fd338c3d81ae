#include "io/Xdmf.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace kf::io {
namespace {

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
    case '&':
      out += "&amp;";
      break;
    case '<':
      out += "&lt;";
      break;
    case '>':
      out += "&gt;";
      break;
    case '"':
      out += "&quot;";
      break;
    default:
      out += c;
    }
  }
  return out;
}

/// XDMF NumberType of an element type. 64-bit ids are declared signed: ParaView's XDMF 3 reader
/// has no unsigned 64-bit type, and ids stay far below 2^63.
const char* number_type(DType t) {
  switch (t) {
  case DType::F32:
  case DType::F64:
    return "Float";
  case DType::U32:
    return "UInt";
  case DType::U64:
  case DType::I32:
    return "Int";
  }
  return "Float";
}

void data_item(std::ostream& out, const SnapshotInfo& frame, const PhaseLayout& phase,
               const FieldLayout& field) {
  out << "<DataItem Dimensions=\"" << phase.count;
  if (field.components != 1)
    out << ' ' << field.components;
  out << "\" NumberType=\"" << number_type(field.type) << "\" Precision=\""
      << dtype_size(field.type) << "\" Format=\"HDF\">" << escape(frame.file) << ":/"
      << escape(phase.name) << '/' << escape(field.name) << "</DataItem>";
}

bool is_position(const FieldLayout& f) {
  return f.name == "position" && f.components == 3 &&
         (f.type == DType::F32 || f.type == DType::F64);
}

bool is_segment(const FieldLayout& f) {
  return f.name == "segment" && f.components == 2 && (f.type == DType::U32 || f.type == DType::U64);
}

void phase_grid(std::ostream& out, const SnapshotInfo& frame, const PhaseLayout& phase) {
  const auto position = std::find_if(phase.fields.begin(), phase.fields.end(), is_position);
  // ParaView rejects empty data items, and a grid without positions cannot be placed.
  if (phase.count == 0 || position == phase.fields.end())
    return;
  // A phase with a 2-component "segment" field (point pairs, as the yarns have) is drawn as
  // lines; any other as points.
  const auto segment = std::find_if(phase.fields.begin(), phase.fields.end(), is_segment);
  out << "        <Grid Name=\"" << escape(phase.name) << "\" GridType=\"Uniform\">\n";
  if (segment != phase.fields.end()) {
    out << "          <Topology TopologyType=\"Polyline\" NumberOfElements=\"" << phase.count
        << "\" NodesPerElement=\"2\">";
    data_item(out, frame, phase, *segment);
    out << "</Topology>\n";
  } else {
    out << "          <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << phase.count
        << "\" NodesPerElement=\"1\"/>\n";
  }
  out << "          <Geometry GeometryType=\"XYZ\">";
  data_item(out, frame, phase, *position);
  out << "</Geometry>\n";
  for (const FieldLayout& field : phase.fields) {
    if (&field == &*position || (field.components != 1 && field.components != 3))
      continue;
    out << "          <Attribute Name=\"" << escape(field.name) << "\" AttributeType=\""
        << (field.components == 1 ? "Scalar" : "Vector") << "\" Center=\"Node\">";
    data_item(out, frame, phase, field);
    out << "</Attribute>\n";
  }
  out << "        </Grid>\n";
}

} // namespace

std::string xdmf_document(const std::vector<SnapshotInfo>& frames) {
  std::ostringstream out;
  out.precision(17); // times round-trip exactly
  out << "<?xml version=\"1.0\" ?>\n"
      << "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n"
      << "  <Domain>\n"
      << "    <Grid Name=\"snapshots\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const SnapshotInfo& frame : frames) {
    out << "      <Grid Name=\"frame_" << frame.index
        << "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
        << "        <Time Value=\"" << frame.time << "\"/>\n";
    for (const PhaseLayout& phase : frame.phases)
      phase_grid(out, frame, phase);
    out << "      </Grid>\n";
  }
  out << "    </Grid>\n  </Domain>\n</Xdmf>\n";
  return out.str();
}

void write_xdmf(const std::string& path, const std::vector<SnapshotInfo>& frames) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << xdmf_document(frames);
    out.close();
    if (!out)
      throw Error(tmp + ": writing the XDMF index failed");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec)
    throw Error(path + ": replacing the XDMF index failed (" + ec.message() + ")");
}

} // namespace kf::io
