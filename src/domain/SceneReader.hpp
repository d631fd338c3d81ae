#pragma once
// Checked access to a parsed TOML scene: typed getters that validate as they read and throw
// kf::SceneError with one line naming the place (FILE:LINE, or the --set override that put the
// value there), the dotted key, what was expected and what was found. Internal to the scene
// loader; the rest of the program sees only the validated kf::Scene.
#include "core/Vec3.hpp"

#include <toml++/toml.h>

#include <array>
#include <cstddef>
#include <initializer_list>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace kf::scene {

/// A numeric interval and its wording for messages ("a number > 0", "a number in (0, 1]").
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false, hi_open = false;

  static Range any() { return {}; }
  static Range positive() { return {0, Range{}.hi, true, false}; }
  static Range at_least(double lo) { return {lo, Range{}.hi, false, false}; }
  static Range above_up_to(double lo, double hi) { return {lo, hi, true, false}; } // (lo, hi]
  static Range closed(double lo, double hi) { return {lo, hi, false, false}; }     // [lo, hi]

  bool contains(double v) const;
  std::string describe() const;
};

/// One allowed spelling of an enumerated value.
template <typename E>
struct Choice {
  std::string_view name;
  E value;
};

/// Name of an enumerator as spelt in scene files; the choice tables are the single source.
template <typename E, std::size_t N>
std::string_view choice_name(const std::array<Choice<E>, N>& choices, E value) {
  for (const auto& c : choices)
    if (c.value == value)
      return c.name;
  return "?";
}

/// Shortest round-trip text of a number ("0.02", not "0.0200000000000000004").
std::string format_number(double v);
std::string format_vec3(const Vec3d& v);
/// What a node holds, for "got ..." ("a string (\"abc\")", "an integer (3)", "a table").
std::string describe(const toml::node& n);
/// The node's value as written ("-0.01", "[1, 0, 0]", "\"abc\"").
std::string repr(const toml::node& n);
/// The known name closest to `word` (Levenshtein distance <= 2, or equal ignoring case).
std::optional<std::string_view> suggest(std::string_view word,
                                        std::span<const std::string_view> known);
/// " (did you mean 'x'?)" or "".
std::string did_you_mean(std::string_view word, std::span<const std::string_view> known);

/// A table of the scene read against its schema. `path` is its dotted name ("fluid.block[1]");
/// the table may be absent (nullptr), in which case every getter leaves its default.
class TableReader {
public:
  TableReader(const std::string& file, const toml::table* table, std::string path,
              const toml::node* anchor = nullptr);

  bool present() const { return table_ != nullptr; }
  const std::string& path() const { return path_; }
  const toml::node* node(std::string_view key) const;
  /// Dotted name of a key of this table ("fluid.spacing").
  std::string key_path(std::string_view key) const;
  /// "FILE:LINE" of a node (this table's header when null), or the --set override it came from.
  std::string where(const toml::node* n) const;

  /// Rejects any key not in `known`, suggesting the nearest known one.
  void allow_only(std::span<const std::string_view> known) const;
  void allow_only(std::initializer_list<std::string_view> known) const {
    allow_only(std::span<const std::string_view>(known.begin(), known.size()));
  }
  /// The key not in `allowed` that comes first in the file, if any.
  std::optional<std::string_view> first_key_not_in(std::span<const std::string_view> allowed) const;

  /// Throws "WHERE: message", WHERE being where(at).
  [[noreturn]] void fail(const toml::node* at, std::string_view message) const;
  /// Throws "WHERE: key 'PATH.key': expected E, got G"; key may carry an index ("min[1]").
  [[noreturn]] void fail_key(const toml::node& at, std::string_view key, std::string_view expected,
                             std::string_view got) const;
  [[noreturn]] void fail_missing(std::string_view key) const;

  // Each reader leaves `out` unchanged and returns false when the key is absent.
  bool read(std::string_view key, double& out, Range range = Range::any()) const;
  bool read(std::string_view key, Vec3d& out) const;
  bool read(std::string_view key, bool& out) const;
  bool read(std::string_view key, std::string& out) const; // non-empty
  bool read_integer(std::string_view key, long& out, long min) const;
  double require(std::string_view key, Range range = Range::any()) const;
  Vec3d require_vec3(std::string_view key) const;

  template <typename E, std::size_t N>
  bool read(std::string_view key, E& out, const std::array<Choice<E>, N>& choices) const {
    const auto names = names_of(choices);
    const toml::node* n = node(key);
    if (!n)
      return false;
    out = choices[choice_index(*n, key, names)].value;
    return true;
  }
  template <typename E, std::size_t N>
  E require(std::string_view key, const std::array<Choice<E>, N>& choices) const {
    E out{};
    if (!read(key, out, choices))
      fail_missing(key);
    return out;
  }
  /// An array of distinct choices (modules = ["fluid", "boundary"]).
  template <typename E, std::size_t N>
  bool read_set(std::string_view key, std::vector<E>& out,
                const std::array<Choice<E>, N>& choices) const {
    const auto names = names_of(choices);
    const toml::node* n = node(key);
    if (!n)
      return false;
    out.clear();
    for (std::size_t i : choice_indices(*n, key, names))
      out.push_back(choices[i].value);
    return true;
  }

  /// The sub-table `key`, absent when the key is; an error when it is not a table.
  TableReader table(std::string_view key) const;
  /// The tables of [[key]], none when absent; an error when it is not an array of tables.
  std::vector<TableReader> array_of_tables(std::string_view key) const;

private:
  template <typename E, std::size_t N>
  static std::array<std::string_view, N> names_of(const std::array<Choice<E>, N>& choices) {
    std::array<std::string_view, N> names{};
    for (std::size_t i = 0; i < N; ++i)
      names[i] = choices[i].name;
    return names;
  }
  std::size_t choice_index(const toml::node& n, std::string_view key,
                           std::span<const std::string_view> names) const;
  std::vector<std::size_t> choice_indices(const toml::node& n, std::string_view key,
                                          std::span<const std::string_view> names) const;
  double number(const toml::node& n, std::string_view key, Range range) const;

  const std::string* file_;
  const toml::table* table_;
  std::string path_;
  const toml::node* anchor_;
};

} // namespace kf::scene
