#include "io/WholeFile.hpp"

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace kf::io {

WholeFile read_whole_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) // an ifstream opens a directory on Linux
    return {{}, EISDIR};
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return {{}, errno ? errno : ENOENT};
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad())
    return {{}, errno ? errno : EIO};
  return {text.str(), 0};
}

} // namespace kf::io
