#include "io/ObjReader.hpp"

#include "core/Error.hpp"
#include "io/WholeFile.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>

namespace kf::io {

namespace {

// Records that carry no surface geometry for us: skipped without a word.
constexpr std::string_view kSkipped[] = {"vt", "vn",     "vp",     "o", "g",
                                         "s",  "usemtl", "mtllib", "l", "p"};

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i]))
      ++i;
    std::size_t j = i;
    while (j < line.size() && !is_space(line[j]))
      ++j;
    if (j > i)
      words.push_back(line.substr(i, j - i));
    i = j;
  }
  return words;
}

class Parser {
public:
  Parser(std::string_view text, const std::string& source) : text_(text) { mesh_.source = source; }

  ObjMesh run() {
    std::string line;
    std::size_t pos = 0;
    while (next_line(pos, line))
      record(line);
    check_forward_references();
    return std::move(mesh_);
  }

private:
  /// The next logical line (a trailing backslash joins the following one), comment removed;
  /// line_ becomes the number of its first physical line.
  bool next_line(std::size_t& pos, std::string& out) {
    if (pos >= text_.size())
      return false;
    out.clear();
    line_ = ++physical_;
    while (pos < text_.size()) {
      std::size_t end = text_.find('\n', pos);
      if (end == std::string_view::npos)
        end = text_.size();
      std::string_view piece = text_.substr(pos, end - pos);
      pos = end + 1;
      while (!piece.empty() && is_space(piece.back()))
        piece.remove_suffix(1);
      if (piece.empty() || piece.back() != '\\') {
        out += piece;
        break;
      }
      piece.remove_suffix(1);
      out += piece;
      out += ' ';
      ++physical_;
    }
    if (const std::size_t hash = out.find('#'); hash != std::string::npos)
      out.resize(hash);
    return true;
  }

  [[noreturn]] void fail(const std::string& what) const {
    throw Error(mesh_.source + ":" + std::to_string(line_) + ": " + what);
  }

  void record(const std::string& line) {
    const auto words = split(line);
    if (words.empty())
      return;
    const std::string_view kind = words[0];
    if (kind == "v")
      vertex(words);
    else if (kind == "f")
      face(words);
    else if (std::find(std::begin(kSkipped), std::end(kSkipped), kind) == std::end(kSkipped))
      fail("unknown OBJ record '" + std::string(kind) +
           "' (geometry is read from v and f; vt, vn, vp, o, g, s, usemtl, mtllib, l, p are "
           "skipped)");
  }

  double number(std::string_view w, const char* what) const {
    std::string_view s = w;
    if (!s.empty() && s[0] == '+')
      s.remove_prefix(1);
    double v = 0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || end != s.data() + s.size() || s.empty())
      fail(std::string(what) + ": expected a number, got '" + std::string(w) + "'");
    if (!std::isfinite(v))
      fail(std::string(what) + ": expected a finite number, got '" + std::string(w) + "'");
    return v;
  }

  void vertex(const std::vector<std::string_view>& w) {
    // x y z, optionally w or an RGB colour (a common extension); all must be numbers.
    if (w.size() < 4 || w.size() > 8)
      fail("vertex: expected 3 coordinates (x y z, optionally w or r g b), got " +
           std::to_string(w.size() - 1) + " value(s)");
    double c[3];
    for (std::size_t i = 1; i < w.size(); ++i) {
      const double v = number(w[i], "vertex");
      if (i <= 3)
        c[i - 1] = v;
    }
    if (mesh_.vertices.size() >= 0x7FFFFFFFu)
      fail("too many vertices");
    mesh_.vertices.push_back({c[0], c[1], c[2]});
  }

  /// An integer (possibly empty when `optional`) of a v/vt/vn reference.
  bool integer(std::string_view s, long& out, bool optional, std::string_view word) const {
    if (s.empty()) {
      if (!optional)
        fail("face: expected a vertex index, got '" + std::string(word) + "'");
      return false;
    }
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
    if (ec != std::errc() || end != s.data() + s.size())
      fail("face: expected an index (v, v/vt, v//vn or v/vt/vn), got '" + std::string(word) + "'");
    return true;
  }

  void face(const std::vector<std::string_view>& w) {
    if (w.size() < 4)
      fail("face: expected at least 3 vertices, got " + std::to_string(w.size() - 1));
    for (std::size_t i = 1; i < w.size(); ++i) {
      const std::string_view word = w[i];
      const std::size_t slash = word.find('/');
      long idx = 0;
      integer(word.substr(0, slash), idx, false, word);
      // The texture and normal references are not used, but must be well formed.
      if (slash != std::string_view::npos) {
        std::string_view rest = word.substr(slash + 1);
        const std::size_t slash2 = rest.find('/');
        long ignored = 0;
        integer(rest.substr(0, slash2), ignored, true, word);
        if (slash2 != std::string_view::npos)
          integer(rest.substr(slash2 + 1), ignored, true, word);
      }
      const long count = static_cast<long>(mesh_.vertices.size());
      if (idx == 0)
        fail("face: vertex index 0 in '" + std::string(word) + "' (OBJ indices start at 1)");
      if (idx < 0) { // relative: -1 is the latest vertex read
        if (-idx > count)
          fail("face: relative vertex index " + std::to_string(idx) + " is out of range (" +
               std::to_string(count) + " vertices read so far)");
        idx = count + idx;
      } else {
        idx -= 1; // checked against the final count at the end (forward references are allowed)
        if (idx >= 0x7FFFFFFFL)
          fail("face: vertex index " + std::string(word) + " is out of range");
      }
      mesh_.face_vertex.push_back(static_cast<std::uint32_t>(idx));
    }
    mesh_.face_start.push_back(static_cast<std::uint32_t>(mesh_.face_vertex.size()));
    mesh_.face_line.push_back(line_);
  }

  void check_forward_references() {
    const std::size_t n = mesh_.vertices.size();
    for (std::size_t f = 0; f < mesh_.faces(); ++f)
      for (std::uint32_t v : mesh_.face(f))
        if (v >= n) {
          line_ = mesh_.face_line[f];
          fail("face: vertex index " + std::to_string(v + 1) + " is out of range (the file has " +
               std::to_string(n) + " vertices)");
        }
  }

  std::string_view text_;
  ObjMesh mesh_;
  int physical_ = 0; // physical lines consumed
  int line_ = 0;     // line of the record being read
};

} // namespace

ObjMesh parse_obj(std::string_view text, const std::string& source_name) {
  return Parser(text, source_name).run();
}

ObjMesh read_obj(const std::string& path) {
  const WholeFile f = read_whole_file(path);
  if (f.error)
    throw Error(path + ": cannot open OBJ file (" + std::strerror(f.error) + ")");
  return parse_obj(f.text, path);
}

std::vector<ObjTriangle> fan_triangles(const ObjMesh& mesh) {
  std::vector<ObjTriangle> out;
  out.reserve(mesh.face_vertex.size());
  for (std::size_t f = 0; f < mesh.faces(); ++f) {
    const auto v = mesh.face(f);
    for (std::size_t k = 1; k + 1 < v.size(); ++k)
      out.push_back({{v[0], v[k], v[k + 1]}, static_cast<std::uint32_t>(f)});
  }
  return out;
}

} // namespace kf::io
