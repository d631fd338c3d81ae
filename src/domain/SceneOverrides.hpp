#pragma once
// --set overrides of a scene ("fluid.spacing=0.02", "fluid.block.0.velocity=[1,0,0]").
#include <toml++/toml.h>

#include <string>
#include <vector>

namespace kf::scene {

/// Applies overrides "dotted.key=value" to a parsed scene, in order, before validation. The value
/// is TOML ("0.02", "[1,0,0]", "\"cubic\""); a value that is not TOML is taken as a bare string
/// (kernel=cubic). A numeric path component indexes an array (fluid.block.0). Every node an
/// override adds carries "--set KEY=VALUE" as its source name, so validation errors about it name
/// the override. Throws SceneError for a malformed override or a bad index.
void apply_overrides(toml::table& root, const std::vector<std::string>& overrides);

} // namespace kf::scene
