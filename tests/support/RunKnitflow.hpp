#pragma once
// The built knitflow app run as a user runs it, for the tests of its command line.
#include <filesystem>
#include <string>

namespace kf::test {

struct CliResult {
  int code = 0;       // exit status
  std::string output; // stdout and stderr together
};

/// Runs `knitflow ARGS` through the shell from `cwd` (empty: the current directory), with `env`
/// ("NAME=value ...") before it.
CliResult run_knitflow(const std::string& args, const std::filesystem::path& cwd = {},
                       const std::string& env = "");

} // namespace kf::test
