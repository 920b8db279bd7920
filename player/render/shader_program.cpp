#include "player/render/shader_program.h"

#include <glad/gl.h>

#include <map>
#include <regex>

#include "common/error.h"

namespace fissure::render {

const std::map<std::string, std::string_view>& embedded_shaders();  // embedded_shaders.cpp (generated)

namespace {

GLenum stage_of(const std::string& name) {
  const std::pair<const char*, GLenum> stages[] = {{".vert.glsl", GL_VERTEX_SHADER},
                                                   {".frag.glsl", GL_FRAGMENT_SHADER},
                                                   {".tesc.glsl", GL_TESS_CONTROL_SHADER},
                                                   {".tese.glsl", GL_TESS_EVALUATION_SHADER},
                                                   {".geom.glsl", GL_GEOMETRY_SHADER}};
  for (const auto& [suffix, stage] : stages) {
    if (name.ends_with(suffix)) return stage;
  }
  throw Error("shader " + name + ": no stage for this file name", "name shaders *.vert.glsl, *.frag.glsl, …");
}

/// The driver's log with "0:LINE(COL)" (Mesa) or "0(LINE)" (NVIDIA) turned into
/// "shaders/NAME:LINE", so the first line of the error says where to look.
std::string locate(const std::string& name, const std::string& log) {
  static const std::regex mesa(R"((^|\n)\s*0:(\d+)\((\d+)\))"), nvidia(R"((^|\n)\s*0\((\d+)\))");
  std::string out = std::regex_replace(log, mesa, "$1shaders/" + name + ":$2:$3");
  return std::regex_replace(out, nvidia, "$1shaders/" + name + ":$2");
}

std::string info_log(GLuint object, bool program) {
  GLint length = 0;
  program ? glGetProgramiv(object, GL_INFO_LOG_LENGTH, &length) : glGetShaderiv(object, GL_INFO_LOG_LENGTH, &length);
  std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
  program ? glGetProgramInfoLog(object, length, nullptr, log.data())
          : glGetShaderInfoLog(object, length, nullptr, log.data());
  while (!log.empty() && (log.back() == '\0' || log.back() == '\n')) log.pop_back();
  return log;
}

GLuint compile(const ShaderSource& source) {
  const GLuint shader = glCreateShader(stage_of(source.name));
  const char* text = source.text.data();
  const auto length = static_cast<GLint>(source.text.size());
  glShaderSource(shader, 1, &text, &length);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (ok) return shader;
  const std::string log = info_log(shader, false);
  glDeleteShader(shader);
  throw Error("shaders/" + source.name + " does not compile:\n" + locate(source.name, log),
              "this is a bug in Fissure's shaders (or the driver lacks OpenGL 4.5); please report it with this log");
}

}  // namespace

ShaderSource embedded_shader(const std::string& name) {
  const auto& shaders = embedded_shaders();
  const auto found = shaders.find(name);
  if (found == shaders.end()) throw Error("no embedded shader " + name, "this is a bug in Fissure's build");
  return {name, found->second};
}

ShaderProgram::ShaderProgram(const std::vector<ShaderSource>& stages) {
  std::vector<GLuint> shaders;
  try {
    for (const ShaderSource& s : stages) shaders.push_back(compile(s));
  } catch (...) {
    for (const GLuint s : shaders) glDeleteShader(s);
    throw;
  }
  m_program = glCreateProgram();
  for (const GLuint s : shaders) glAttachShader(m_program, s);
  glLinkProgram(m_program);
  for (const GLuint s : shaders) glDeleteShader(s);
  GLint ok = 0;
  glGetProgramiv(m_program, GL_LINK_STATUS, &ok);
  if (ok) return;
  std::string names;
  for (const ShaderSource& s : stages) names += (names.empty() ? "shaders/" : ", shaders/") + s.name;
  const std::string log = info_log(m_program, true);
  glDeleteProgram(m_program);
  m_program = 0;
  throw Error(names + " do not link:\n" + log, "this is a bug in Fissure's shaders; please report it with this log");
}

ShaderProgram::~ShaderProgram() {
  if (m_program != 0) glDeleteProgram(m_program);
}

void ShaderProgram::use() const { glUseProgram(m_program); }

int ShaderProgram::uniform(const char* name) const { return glGetUniformLocation(m_program, name); }

}  // namespace fissure::render
