#pragma once
/// Owning handles for GL objects (buffers, vertex arrays, framebuffers, renderbuffers):
/// deleted with their owner, movable, never copied. Need a current context.

#include <cstddef>
#include <utility>

namespace fissure::render {

class GlName {
 public:
  enum class Kind { Buffer, VertexArray, Framebuffer, Renderbuffer };
  explicit GlName(Kind kind);
  ~GlName();
  GlName(GlName&& other) noexcept : m_kind(other.m_kind), m_name(std::exchange(other.m_name, 0)) {}
  GlName& operator=(GlName&&) = delete;
  GlName(const GlName&) = delete;
  GlName& operator=(const GlName&) = delete;
  [[nodiscard]] unsigned get() const { return m_name; }

 private:
  Kind m_kind;
  unsigned m_name = 0;
};

/// A shader storage buffer that grows as needed: upload() replaces its contents.
class StorageBuffer {
 public:
  StorageBuffer() : m_buffer(GlName::Kind::Buffer) {}
  /// Uploads `bytes` bytes; returns how many went to the GPU.
  std::size_t upload(const void* data, std::size_t bytes);
  void bind(unsigned binding) const;
  [[nodiscard]] std::size_t size() const { return m_size; }

 private:
  GlName m_buffer;
  std::size_t m_capacity = 0, m_size = 0;
};

}  // namespace fissure::render
