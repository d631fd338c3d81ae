#include "support/RunKnitflow.hpp"

#include "support/TestPaths.hpp"

#include <array>
#include <cstdio>
#include <sys/wait.h>

namespace kf::test {

CliResult run_knitflow(const std::string& args, const std::filesystem::path& cwd,
                       const std::string& env) {
  const std::string cd = cwd.empty() ? "" : "cd '" + cwd.string() + "' && ";
  const std::string cmd =
      cd + env + (env.empty() ? "" : " ") + knitflow_exe().string() + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), buf.size(), p))
    out += buf.data();
  const int status = pclose(p);
  return {WEXITSTATUS(status), out};
}

} // namespace kf::test
