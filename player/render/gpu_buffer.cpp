#include "player/render/gpu_buffer.h"

#include <glad/gl.h>

#include <algorithm>

namespace fissure::render {

GlName::GlName(Kind kind) : m_kind(kind) {
  switch (kind) {
    case Kind::Buffer: glCreateBuffers(1, &m_name); break;
    case Kind::VertexArray: glCreateVertexArrays(1, &m_name); break;
    case Kind::Framebuffer: glCreateFramebuffers(1, &m_name); break;
    case Kind::Renderbuffer: glCreateRenderbuffers(1, &m_name); break;
  }
}

GlName::~GlName() {
  if (m_name == 0) return;
  switch (m_kind) {
    case Kind::Buffer: glDeleteBuffers(1, &m_name); break;
    case Kind::VertexArray: glDeleteVertexArrays(1, &m_name); break;
    case Kind::Framebuffer: glDeleteFramebuffers(1, &m_name); break;
    case Kind::Renderbuffer: glDeleteRenderbuffers(1, &m_name); break;
  }
}

std::size_t StorageBuffer::upload(const void* data, std::size_t bytes) {
  // An empty buffer cannot be bound as storage: keep at least a few bytes.
  const std::size_t needed = std::max<std::size_t>(bytes, 16);
  if (needed > m_capacity) {
    m_capacity = std::max(needed, m_capacity + m_capacity / 2);
    glNamedBufferData(m_buffer.get(), static_cast<GLsizeiptr>(m_capacity), nullptr, GL_DYNAMIC_DRAW);
  }
  if (bytes > 0) glNamedBufferSubData(m_buffer.get(), 0, static_cast<GLsizeiptr>(bytes), data);
  m_size = bytes;
  return bytes;
}

void StorageBuffer::bind(unsigned binding) const {
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, binding, m_buffer.get());
}

}  // namespace fissure::render
