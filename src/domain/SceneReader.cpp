#include "domain/SceneReader.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <sstream>

namespace kf::scene {

namespace {

std::string element_key(std::string_view key, std::size_t i) {
  return std::string(key) + "[" + std::to_string(i) + "]";
}

std::string quoted_list(std::span<const std::string_view> names) {
  std::string out;
  for (std::string_view n : names)
    out += (out.empty() ? "\"" : ", \"") + std::string(n) + "\"";
  return out;
}

bool iequal(std::string_view a, std::string_view b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](char x, char y) {
    return std::tolower(static_cast<unsigned char>(x)) ==
           std::tolower(static_cast<unsigned char>(y));
  });
}

std::size_t levenshtein(std::string_view a, std::string_view b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j)
    prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1])});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

// toml++ prints strings and dates in TOML syntax; numbers are formatted by format_number.
std::string toml_text(const toml::node& n) {
  std::ostringstream os;
  os << toml::toml_formatter{n, toml::format_flags::none};
  return os.str();
}

} // namespace

bool Range::contains(double v) const {
  return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
}

std::string Range::describe() const {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && has_hi)
    return "a number in " + std::string(lo_open ? "(" : "[") + format_number(lo) + ", " +
           format_number(hi) + (hi_open ? ")" : "]");
  if (has_lo)
    return std::string("a number ") + (lo_open ? "> " : ">= ") + format_number(lo);
  if (has_hi)
    return std::string("a number ") + (hi_open ? "< " : "<= ") + format_number(hi);
  return "a number";
}

std::string format_number(double v) {
  if (std::isnan(v))
    return "nan";
  if (std::isinf(v))
    return v > 0 ? "inf" : "-inf";
  char buf[32];
  auto res = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, res.ptr);
}

std::string format_vec3(const Vec3d& v) {
  std::string out = "["; // appended piecewise: GCC 12 warns (-Wrestrict) on a chain of +
  out += format_number(v.x);
  out += ", ";
  out += format_number(v.y);
  out += ", ";
  out += format_number(v.z);
  return out + "]";
}

std::string repr(const toml::node& n) {
  if (auto* f = n.as_floating_point())
    return format_number(f->get());
  if (auto* a = n.as_array()) {
    std::string out = "[";
    for (std::size_t i = 0; i < a->size(); ++i)
      out += (i ? ", " : "") + repr(*a->get(i));
    return out + "]";
  }
  if (n.is_table())
    return "{...}";
  return toml_text(n);
}

std::string describe(const toml::node& n) {
  switch (n.type()) {
  case toml::node_type::string:
    return "a string (" + repr(n) + ")";
  case toml::node_type::integer:
    return "an integer (" + repr(n) + ")";
  case toml::node_type::floating_point:
    return "a number (" + repr(n) + ")";
  case toml::node_type::boolean:
    return "a boolean (" + repr(n) + ")";
  case toml::node_type::array:
    return n.as_array()->empty() ? "an empty array" : "an array (" + repr(n) + ")";
  case toml::node_type::table:
    return "a table";
  default:
    return "a date/time (" + repr(n) + ")";
  }
}

std::optional<std::string_view> suggest(std::string_view word,
                                        std::span<const std::string_view> known) {
  std::optional<std::string_view> best;
  std::size_t best_distance = 3; // only suggest within distance 2
  for (std::string_view k : known) {
    const std::size_t d = iequal(word, k) ? 0 : levenshtein(word, k);
    if (d < best_distance) {
      best = k;
      best_distance = d;
    }
  }
  return best;
}

std::string did_you_mean(std::string_view word, std::span<const std::string_view> known) {
  auto s = suggest(word, known);
  return s ? " (did you mean '" + std::string(*s) + "'?)" : "";
}

TableReader::TableReader(const std::string& file, const toml::table* table, std::string path,
                         const toml::node* anchor)
    : file_(&file), table_(table), path_(std::move(path)), anchor_(anchor ? anchor : table) {}

const toml::node* TableReader::node(std::string_view key) const {
  return table_ ? table_->get(key) : nullptr;
}

std::string TableReader::key_path(std::string_view key) const {
  return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

std::string TableReader::where(const toml::node* n) const {
  const toml::node* at = n ? n : anchor_;
  if (at) {
    const toml::source_region& src = at->source();
    // Nodes from an override were parsed with the override itself as their source name.
    if (src.path && *src.path != *file_)
      return *src.path;
    if (src.begin.line > 0)
      return *file_ + ":" + std::to_string(src.begin.line);
  }
  return *file_ + ":1";
}

std::optional<std::string_view>
TableReader::first_key_not_in(std::span<const std::string_view> allowed) const {
  if (!table_)
    return std::nullopt;
  std::optional<std::string_view> first;
  toml::source_index first_line = 0;
  for (auto&& [k, v] : *table_) {
    if (std::find(allowed.begin(), allowed.end(), k.str()) != allowed.end())
      continue;
    if (!first || v.source().begin.line < first_line) {
      first = k.str();
      first_line = v.source().begin.line;
    }
  }
  return first;
}

void TableReader::allow_only(std::span<const std::string_view> known) const {
  auto bad = first_key_not_in(known);
  if (!bad)
    return;
  const toml::node* n = node(*bad);
  const bool is_table = n->is_table() || n->is_array_of_tables();
  fail(n, std::string("unknown ") + (is_table ? "table" : "key") + " '" + key_path(*bad) + "'" +
              did_you_mean(*bad, known));
}

void TableReader::fail(const toml::node* at, std::string_view message) const {
  throw SceneError(where(at) + ": " + std::string(message));
}

void TableReader::fail_key(const toml::node& at, std::string_view key, std::string_view expected,
                           std::string_view got) const {
  fail(&at, "key '" + key_path(key) + "': expected " + std::string(expected) + ", got " +
                std::string(got));
}

void TableReader::fail_missing(std::string_view key) const {
  fail(nullptr, "table '" + path_ + "': missing required key '" + std::string(key) + "'");
}

double TableReader::number(const toml::node& n, std::string_view key, Range range) const {
  double v = 0;
  if (auto* i = n.as_integer())
    v = static_cast<double>(i->get());
  else if (auto* f = n.as_floating_point())
    v = f->get();
  else
    fail_key(n, key, "a number", describe(n));
  if (!std::isfinite(v))
    fail_key(n, key, "a finite number", repr(n));
  if (!range.contains(v))
    fail_key(n, key, range.describe(), repr(n));
  return v;
}

bool TableReader::read(std::string_view key, double& out, Range range) const {
  const toml::node* n = node(key);
  if (n)
    out = number(*n, key, range);
  return n != nullptr;
}

bool TableReader::read(std::string_view key, Vec3d& out) const {
  const toml::node* n = node(key);
  if (!n)
    return false;
  const toml::array* a = n->as_array();
  if (!a || a->size() != 3)
    fail_key(*n, key, "an array of 3 numbers", describe(*n));
  double c[3];
  for (std::size_t i = 0; i < 3; ++i)
    c[i] = number(*a->get(i), element_key(key, i), Range::any());
  out = {c[0], c[1], c[2]};
  return true;
}

bool TableReader::read(std::string_view key, bool& out) const {
  const toml::node* n = node(key);
  if (!n)
    return false;
  if (!n->is_boolean())
    fail_key(*n, key, "a boolean (true or false)", describe(*n));
  out = n->as_boolean()->get();
  return true;
}

bool TableReader::read(std::string_view key, std::string& out) const {
  const toml::node* n = node(key);
  if (!n)
    return false;
  if (!n->is_string() || n->as_string()->get().empty())
    fail_key(*n, key, "a non-empty string", describe(*n));
  out = n->as_string()->get();
  return true;
}

bool TableReader::read_integer(std::string_view key, long& out, long min) const {
  const toml::node* n = node(key);
  if (!n)
    return false;
  const std::string expected = "an integer >= " + std::to_string(min);
  if (!n->is_integer())
    fail_key(*n, key, expected, describe(*n));
  const auto v = n->as_integer()->get();
  if (v < min)
    fail_key(*n, key, expected, repr(*n));
  out = static_cast<long>(v);
  return true;
}

double TableReader::require(std::string_view key, Range range) const {
  double v = 0;
  if (!read(key, v, range))
    fail_missing(key);
  return v;
}

Vec3d TableReader::require_vec3(std::string_view key) const {
  Vec3d v{};
  if (!read(key, v))
    fail_missing(key);
  return v;
}

std::size_t TableReader::choice_index(const toml::node& n, std::string_view key,
                                      std::span<const std::string_view> names) const {
  const std::string expected = "one of " + quoted_list(names);
  if (!n.is_string())
    fail_key(n, key, expected, describe(n));
  const std::string& s = n.as_string()->get();
  auto it = std::find(names.begin(), names.end(), s);
  if (it == names.end())
    fail_key(n, key, expected, repr(n) + did_you_mean(s, names));
  return static_cast<std::size_t>(it - names.begin());
}

std::vector<std::size_t>
TableReader::choice_indices(const toml::node& n, std::string_view key,
                            std::span<const std::string_view> names) const {
  const toml::array* a = n.as_array();
  if (!a)
    fail_key(n, key, "an array of strings, each one of " + quoted_list(names), describe(n));
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < a->size(); ++i) {
    const toml::node& e = *a->get(i);
    const std::size_t idx = choice_index(e, element_key(key, i), names);
    if (std::find(out.begin(), out.end(), idx) != out.end())
      fail_key(e, element_key(key, i), "each value at most once", repr(e) + " a second time");
    out.push_back(idx);
  }
  return out;
}

TableReader TableReader::table(std::string_view key) const {
  const toml::node* n = node(key);
  if (n && !n->is_table())
    fail_key(*n, key, "a table", describe(*n));
  return TableReader(*file_, n ? n->as_table() : nullptr, key_path(key));
}

std::vector<TableReader> TableReader::array_of_tables(std::string_view key) const {
  const toml::node* n = node(key);
  if (!n)
    return {};
  const toml::array* a = n->as_array();
  if (!a || (!a->empty() && !a->is_array_of_tables()))
    fail_key(*n, key, "an array of tables ([[" + key_path(key) + "]])", describe(*n));
  std::vector<TableReader> out;
  for (std::size_t i = 0; i < a->size(); ++i)
    out.emplace_back(*file_, a->get(i)->as_table(), element_key(key_path(key), i));
  return out;
}

} // namespace kf::scene
