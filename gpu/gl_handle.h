// RAII ownership of OpenGL object names (buffers, textures, programs, shaders, syncs).
//
// A GlHandle owns one GL name and deletes it in its destructor; it is move-only. It must be
// destroyed while the context that created it is current (contexts outlive their objects).
#pragma once

#include <epoxy/gl.h>

#include <utility>

namespace loam::gpu {

template <typename Name, void (*Delete)(Name)>
class GlHandle {
 public:
  GlHandle() = default;
  explicit GlHandle(Name name) : name_(name) {}
  ~GlHandle() { reset(); }
  GlHandle(GlHandle&& other) noexcept : name_(std::exchange(other.name_, Name{})) {}
  GlHandle& operator=(GlHandle&& other) noexcept {
    if (this != &other) {
      reset();
      name_ = std::exchange(other.name_, Name{});
    }
    return *this;
  }
  GlHandle(const GlHandle&) = delete;
  GlHandle& operator=(const GlHandle&) = delete;

  Name get() const { return name_; }
  explicit operator bool() const { return name_ != Name{}; }
  void reset() {
    if (name_ != Name{}) Delete(name_);
    name_ = Name{};
  }

 private:
  Name name_{};
};

namespace detail {
inline void delete_buffer(GLuint n) { glDeleteBuffers(1, &n); }
inline void delete_texture(GLuint n) { glDeleteTextures(1, &n); }
inline void delete_program(GLuint n) { glDeleteProgram(n); }
inline void delete_shader(GLuint n) { glDeleteShader(n); }
inline void delete_sync(GLsync s) { glDeleteSync(s); }
inline void delete_framebuffer(GLuint n) { glDeleteFramebuffers(1, &n); }
inline void delete_vertex_array(GLuint n) { glDeleteVertexArrays(1, &n); }
}  // namespace detail

using GlBuffer = GlHandle<GLuint, detail::delete_buffer>;
using GlTexture = GlHandle<GLuint, detail::delete_texture>;
using GlProgram = GlHandle<GLuint, detail::delete_program>;
using GlShader = GlHandle<GLuint, detail::delete_shader>;
using GlSync = GlHandle<GLsync, detail::delete_sync>;
using GlFramebuffer = GlHandle<GLuint, detail::delete_framebuffer>;
using GlVertexArray = GlHandle<GLuint, detail::delete_vertex_array>;

inline GlBuffer make_buffer() {
  GLuint n = 0;
  glCreateBuffers(1, &n);
  return GlBuffer(n);
}
inline GlTexture make_texture(GLenum target) {
  GLuint n = 0;
  glCreateTextures(target, 1, &n);
  return GlTexture(n);
}

}  // namespace loam::gpu
