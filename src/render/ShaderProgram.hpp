#pragma once
// A linked GLSL program from vertex and fragment sources, or from a compute shader's. A compile
// or link failure is a kf::Error that names the program, the stage and the driver's log (with its
// line numbers).
#include <string>

namespace kf::render {

/// `source` with `snippet` inserted after its first line (the #version): GLSL has no #include.
std::string with_after_version(const char* source, const char* snippet);

class ShaderProgram {
public:
  /// name: where the sources came from (a shader file's name), for errors.
  ShaderProgram(const std::string& name, const std::string& vertex, const std::string& fragment);
  /// A compute program (OpenGL 4.3+: NVIDIA's and Mesa llvmpipe's 4.5 both run it).
  static ShaderProgram compute(const std::string& name, const std::string& source) {
    return ShaderProgram(name, source);
  }
  ShaderProgram(ShaderProgram&& other) noexcept : program_(other.program_) { other.program_ = 0; }
  ~ShaderProgram();
  ShaderProgram(const ShaderProgram&) = delete;
  ShaderProgram& operator=(const ShaderProgram&) = delete;

  void use() const;
  unsigned id() const { return program_; }

private:
  ShaderProgram(const std::string& name, const std::string& compute_source);
  void link(const std::string& name, const unsigned* shaders, int count);
  unsigned program_ = 0;
};

} // namespace kf::render
