#include "domain/SceneOverrides.hpp"

#include "core/Error.hpp"
#include "domain/SceneReader.hpp"

#include <charconv>
#include <string_view>

namespace kf::scene {

namespace {

std::string trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string_view::npos)
    return {};
  return std::string(s.substr(b, s.find_last_not_of(" \t") - b + 1));
}

[[noreturn]] void fail(const std::string& label, const std::string& message) {
  throw SceneError(label + ": " + message);
}

/// Parses one override into a document of its own ("a.b = value") whose nodes are named `label`.
toml::table parse_override(const std::string& text, const std::string& label) {
  const auto eq = text.find('=');
  if (eq == std::string::npos)
    fail(label, "malformed override: expected KEY=VALUE (e.g. fluid.spacing=0.02)");
  if (text.find_first_of("\r\n") != std::string::npos)
    fail(label, "malformed override: expected a single line");
  const std::string key = trim(std::string_view(text).substr(0, eq));
  const std::string value = trim(std::string_view(text).substr(eq + 1));
  if (key.empty())
    fail(label, "malformed override: expected a key before '='");
  if (value.empty())
    fail(label, "malformed override: expected a value after '='");
  try {
    return toml::parse(key + " = " + value, std::string_view(label));
  } catch (const toml::parse_error&) {
    // Not a TOML value: take it as a bare string, so --set solver.kernel=cubic works.
  }
  try {
    return toml::parse(key + " = " + repr(toml::value<std::string>(value)),
                       std::string_view(label));
  } catch (const toml::parse_error& e) {
    fail(label, "malformed override: " + std::string(e.description()));
  }
}

void merge_table(toml::table& dst, toml::table& patch, const std::string& path,
                 const std::string& label);
void merge_array(toml::array& dst, toml::table& patch, const std::string& path,
                 const std::string& label);

/// Merges a table from the override into a container it names; false when `value` should
/// replace `target` instead (a leaf, or a key the scene lacks).
bool merge_into(toml::node* target, toml::node& value, const std::string& path,
                const std::string& label) {
  if (!target || !value.is_table())
    return false;
  if (auto* t = target->as_table())
    merge_table(*t, *value.as_table(), path, label);
  else if (auto* a = target->as_array())
    merge_array(*a, *value.as_table(), path, label);
  else
    return false;
  return true;
}

void merge_table(toml::table& dst, toml::table& patch, const std::string& path,
                 const std::string& label) {
  for (auto&& [k, v] : patch) {
    const std::string sub = path.empty() ? std::string(k.str()) : path + "." + std::string(k.str());
    // Moving (not copying) keeps the node's source, which names the override.
    if (!merge_into(dst.get(k.str()), v, sub, label))
      dst.insert_or_assign(k.str(), std::move(v));
  }
}

void merge_array(toml::array& dst, toml::table& patch, const std::string& path,
                 const std::string& label) {
  for (auto&& [k, v] : patch) {
    const std::string_view s = k.str();
    std::size_t i = 0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), i);
    if (ec != std::errc{} || end != s.data() + s.size() || i >= dst.size()) {
      const std::string expected = dst.empty()
                                       ? "an element index (the array is empty)"
                                       : "an element index 0.." + std::to_string(dst.size() - 1);
      fail(label, "key '" + path + "': expected " + expected + ", got '" + std::string(s) + "'");
    }
    const std::string sub = path + "[" + std::string(s) + "]";
    if (!merge_into(dst.get(i), v, sub, label))
      dst.replace(dst.cbegin() + static_cast<std::ptrdiff_t>(i), std::move(v));
  }
}

} // namespace

void apply_overrides(toml::table& root, const std::vector<std::string>& overrides) {
  for (const std::string& text : overrides) {
    const std::string label = "--set " + text;
    toml::table patch = parse_override(text, label);
    merge_table(root, patch, "", label);
  }
}

} // namespace kf::scene
