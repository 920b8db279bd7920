#pragma once
/// A linked GL program from shader files (shaders/*.glsl, embedded at build time).
/// A compile or link failure throws fissure::Error naming the file and line with the
/// driver's log: each file is one stage, so the driver's line numbers are the file's.

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace fissure::render {

/// One stage's source: the file name (its extension picks the stage: .vert.glsl,
/// .frag.glsl, .tesc.glsl, .tese.glsl, .geom.glsl) and its text.
struct ShaderSource {
  std::string name;
  std::string_view text;
};

/// The embedded shader `name` (e.g. "embedded.vert.glsl"); throws if there is none.
ShaderSource embedded_shader(const std::string& name);

class ShaderProgram {
 public:
  /// Compiles and links; needs a current context. Throws fissure::Error on failure.
  explicit ShaderProgram(const std::vector<ShaderSource>& stages);
  ~ShaderProgram();
  ShaderProgram(ShaderProgram&& other) noexcept : m_program(std::exchange(other.m_program, 0)) {}
  ShaderProgram& operator=(ShaderProgram&&) = delete;
  ShaderProgram(const ShaderProgram&) = delete;
  ShaderProgram& operator=(const ShaderProgram&) = delete;

  void use() const;
  [[nodiscard]] unsigned id() const { return m_program; }
  /// The location of uniform `name` (-1 when the program does not use it).
  [[nodiscard]] int uniform(const char* name) const;

 private:
  unsigned m_program = 0;
};

}  // namespace fissure::render
