#pragma once
// A text file read whole, or why it could not be: the scene loader and the OBJ reader word their
// own errors ("cannot open scene file", "cannot open OBJ file") around the same reading.
#include <string>

namespace kf::io {

struct WholeFile {
  std::string text;
  int error = 0; // 0, or the errno that says why nothing was read (EISDIR for a directory)
};

WholeFile read_whole_file(const std::string& path);

} // namespace kf::io
