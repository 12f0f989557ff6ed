// Uniform blocks mirrored by C++ structs, checked against the linked program rather than
// trusted: a misspelt or mislaid member is an error at creation, not a uniform that silently
// reads zero. A struct mirrors a std140 block member for member (its own static_asserts pin
// the std140 offsets); verify_uniform_block() then asks the program for the block's size and
// each member's offset by name, and checks that the block has no member the struct lacks.
// UniformBuffer<T> holds one or more T in a buffer, each at an offset the GL's alignment
// allows, and binds one of them to the block's binding point.
//
// Needs the GL 4.5 context current; not thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "gpu/gl_handle.h"
#include "protocol/result.h"

namespace loam::gpu {

struct UniformBlockMember {
  std::string_view name;  // as GLSL names it (a block without an instance name: the bare name)
  size_t offset;          // offsetof in the mirroring struct
};
#define LOAM_UNIFORM_MEMBER(Struct, field, glsl_name) \
  ::loam::gpu::UniformBlockMember { glsl_name, offsetof(Struct, field) }

// The program's uniform block `block` is exactly `size` bytes and its active members are
// exactly `members`, each at its offset. Errors name the block and the member.
Status verify_uniform_block(GLuint program, std::string_view block, size_t size,
                            std::span<const UniformBlockMember> members);

// Every active uniform of the program lives in a block, apart from samplers and images
// (which take their units from layout bindings): nothing is left to a by-name lookup.
Status verify_no_loose_uniforms(GLuint program);

// The offset alignment uniform buffer bindings need (GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT).
size_t uniform_buffer_alignment();

template <typename T>
class UniformBuffer {
 public:
  static_assert(sizeof(T) % 16 == 0, "a std140 block is a whole number of vec4");
  explicit UniformBuffer(int32_t count = 1)
      : count_(count),
        stride_((sizeof(T) + uniform_buffer_alignment() - 1) / uniform_buffer_alignment() *
                uniform_buffer_alignment()) {
    buffer_ = make_buffer();
    glNamedBufferStorage(buffer_.get(), GLsizeiptr(stride_ * size_t(count)), nullptr, GL_DYNAMIC_STORAGE_BIT);
  }
  void write(int32_t index, const T& value) {
    glNamedBufferSubData(buffer_.get(), GLintptr(stride_ * size_t(index)), sizeof(T), &value);
  }
  void bind(GLuint binding, int32_t index = 0) const {
    glBindBufferRange(GL_UNIFORM_BUFFER, binding, buffer_.get(), GLintptr(stride_ * size_t(index)),
                      sizeof(T));
  }
  int32_t count() const { return count_; }
  size_t bytes() const { return stride_ * size_t(count_); }

 private:
  int32_t count_;
  size_t stride_;
  GlBuffer buffer_;
};

}  // namespace loam::gpu
