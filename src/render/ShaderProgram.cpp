#include "render/ShaderProgram.hpp"

#include "core/Error.hpp"

#include <epoxy/gl.h>

#include <string_view>

namespace kf::render {

std::string with_after_version(const char* source, const char* snippet) {
  const std::string_view s(source);
  const std::size_t line = s.find('\n') + 1; // after "#version ..."
  std::string out(s.substr(0, line));
  out.append(snippet);
  out.append(s.substr(line));
  return out;
}

namespace {

unsigned compile(const std::string& name, GLenum stage, const std::string& source) {
  const unsigned s = glCreateShader(stage);
  const char* text = source.c_str();
  glShaderSource(s, 1, &text, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    GLint len = 0;
    glGetShaderiv(s, GL_INFO_LOG_LENGTH, &len);
    std::string log(std::size_t(len > 0 ? len : 1), '\0');
    glGetShaderInfoLog(s, GLsizei(log.size()), nullptr, log.data());
    glDeleteShader(s);
    const std::string what = stage == GL_VERTEX_SHADER     ? "vertex"
                             : stage == GL_FRAGMENT_SHADER ? "fragment"
                                                           : "compute";
    throw Error("render: " + name + ": the " + what + " shader does not compile:\n" + log.c_str());
  }
  return s;
}

} // namespace

ShaderProgram::ShaderProgram(const std::string& name, const std::string& vertex,
                             const std::string& fragment) {
  const unsigned vs = compile(name, GL_VERTEX_SHADER, vertex);
  unsigned fs = 0;
  try {
    fs = compile(name, GL_FRAGMENT_SHADER, fragment);
  } catch (...) {
    glDeleteShader(vs);
    throw;
  }
  const unsigned both[] = {vs, fs};
  link(name, both, 2);
}

ShaderProgram::ShaderProgram(const std::string& name, const std::string& compute_source) {
  const unsigned cs = compile(name, GL_COMPUTE_SHADER, compute_source);
  link(name, &cs, 1);
}

void ShaderProgram::link(const std::string& name, const unsigned* shaders, int count) {
  program_ = glCreateProgram();
  for (int i = 0; i < count; ++i)
    glAttachShader(program_, shaders[i]);
  glLinkProgram(program_);
  for (int i = 0; i < count; ++i)
    glDeleteShader(shaders[i]); // the program keeps them while it lives
  GLint ok = 0;
  glGetProgramiv(program_, GL_LINK_STATUS, &ok);
  if (!ok) {
    GLint len = 0;
    glGetProgramiv(program_, GL_INFO_LOG_LENGTH, &len);
    std::string log(std::size_t(len > 0 ? len : 1), '\0');
    glGetProgramInfoLog(program_, GLsizei(log.size()), nullptr, log.data());
    glDeleteProgram(program_);
    program_ = 0;
    throw Error("render: " + name + ": the program does not link:\n" + std::string(log.c_str()));
  }
}

ShaderProgram::~ShaderProgram() {
  glDeleteProgram(program_);
}

void ShaderProgram::use() const {
  glUseProgram(program_);
}

} // namespace kf::render
