#pragma once
#include <filesystem>
#include <string>

namespace kf::test {

/// Root of the source tree (scenes/, tests/data/).
std::filesystem::path source_dir();
/// tests/data.
std::filesystem::path data_dir();
/// Path of the built knitflow executable (the environment's KF_KNITFLOW where set).
std::filesystem::path knitflow_exe();
/// A fresh, empty directory for one test's output (under the build tree), removed first if present.
std::filesystem::path scratch_dir(const std::string& name);

} // namespace kf::test
