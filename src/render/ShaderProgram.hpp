#pragma once
// A linked GLSL program from vertex and fragment sources. A compile or link failure is a
// kf::Error that names the program, the stage and the driver's log (with its line numbers).
#include <string>

namespace kf::render {

class ShaderProgram {
public:
  /// name: where the sources came from (a shader file's name), for errors.
  ShaderProgram(const std::string& name, const std::string& vertex, const std::string& fragment);
  ~ShaderProgram();
  ShaderProgram(const ShaderProgram&) = delete;
  ShaderProgram& operator=(const ShaderProgram&) = delete;

  void use() const;
  unsigned id() const { return program_; }

private:
  unsigned program_ = 0;
};

} // namespace kf::render
