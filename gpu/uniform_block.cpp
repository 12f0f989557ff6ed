#include "gpu/uniform_block.h"

#include <string>
#include <vector>

namespace loam::gpu {

namespace {

std::string uniform_name(GLuint program, GLuint index) {
  GLint length = 0;
  glGetActiveUniformsiv(program, 1, &index, GL_UNIFORM_NAME_LENGTH, &length);
  std::string name(size_t(std::max(length, 1)), '\0');
  GLsizei written = 0;
  glGetActiveUniformName(program, index, length, &written, name.data());
  name.resize(size_t(written));
  return name;
}

bool is_opaque(GLenum type) {
  switch (type) {
    case GL_SAMPLER_2D:
    case GL_SAMPLER_3D:
    case GL_SAMPLER_2D_ARRAY:
    case GL_SAMPLER_CUBE:
    case GL_INT_SAMPLER_2D:
    case GL_INT_SAMPLER_2D_ARRAY:
    case GL_UNSIGNED_INT_SAMPLER_2D:
    case GL_UNSIGNED_INT_SAMPLER_2D_ARRAY:
    case GL_SAMPLER_2D_SHADOW:
    case GL_SAMPLER_2D_ARRAY_SHADOW:
    case GL_IMAGE_2D:
    case GL_IMAGE_2D_ARRAY:
    case GL_INT_IMAGE_2D:
    case GL_INT_IMAGE_2D_ARRAY:
    case GL_UNSIGNED_INT_IMAGE_2D:
    case GL_UNSIGNED_INT_IMAGE_2D_ARRAY: return true;
    default: return false;
  }
}

}  // namespace

Status verify_uniform_block(GLuint program, std::string_view block, size_t size,
                            std::span<const UniformBlockMember> members) {
  const std::string block_name(block);
  const GLuint index = glGetUniformBlockIndex(program, block_name.c_str());
  if (index == GL_INVALID_INDEX)
    return make_error(ErrorCode::kNotFound, "uniform block " + block_name, "the program has no such block");
  GLint data_size = 0, active = 0;
  glGetActiveUniformBlockiv(program, index, GL_UNIFORM_BLOCK_DATA_SIZE, &data_size);
  glGetActiveUniformBlockiv(program, index, GL_UNIFORM_BLOCK_ACTIVE_UNIFORMS, &active);
  if (size_t(data_size) != size) {
    return make_error(ErrorCode::kInvalidArgument, "uniform block " + block_name,
                      "is " + std::to_string(data_size) + " bytes in the program, " + std::to_string(size) +
                          " in its C++ struct");
  }
  for (const UniformBlockMember& m : members) {
    const std::string name(m.name);
    const char* names[] = {name.c_str()};
    GLuint u = GL_INVALID_INDEX;
    glGetUniformIndices(program, 1, names, &u);
    GLint in_block = -1, offset = -1;
    if (u != GL_INVALID_INDEX) {
      glGetActiveUniformsiv(program, 1, &u, GL_UNIFORM_BLOCK_INDEX, &in_block);
      glGetActiveUniformsiv(program, 1, &u, GL_UNIFORM_OFFSET, &offset);
    }
    if (u == GL_INVALID_INDEX || GLuint(in_block) != index) {
      return make_error(ErrorCode::kNotFound, "uniform block " + block_name,
                        "has no member \"" + name + "\" (misspelt, or not in this block)");
    }
    if (size_t(offset) != m.offset) {
      return make_error(ErrorCode::kInvalidArgument, "uniform block " + block_name,
                        "member \"" + name + "\" is at offset " + std::to_string(offset) +
                            " in the program, " + std::to_string(m.offset) + " in its C++ struct");
    }
  }
  if (size_t(active) != members.size()) {
    // Name the members the struct does not mirror.
    std::vector<GLint> indices(static_cast<size_t>(active));
    glGetActiveUniformBlockiv(program, index, GL_UNIFORM_BLOCK_ACTIVE_UNIFORM_INDICES, indices.data());
    std::string missing;
    for (GLint i : indices) {
      const std::string name = uniform_name(program, GLuint(i));
      bool listed = false;
      for (const UniformBlockMember& m : members) listed = listed || name == m.name;
      if (!listed) missing += (missing.empty() ? "" : ", ") + name;
    }
    return make_error(ErrorCode::kInvalidArgument, "uniform block " + block_name,
                      "has " + std::to_string(active) + " members, its C++ struct mirrors " +
                          std::to_string(members.size()) + "; not mirrored: " + missing);
  }
  return {};
}

Status verify_no_loose_uniforms(GLuint program) {
  GLint count = 0;
  glGetProgramiv(program, GL_ACTIVE_UNIFORMS, &count);
  for (GLuint u = 0; u < GLuint(count); ++u) {
    GLint block = -1, type = 0;
    glGetActiveUniformsiv(program, 1, &u, GL_UNIFORM_BLOCK_INDEX, &block);
    glGetActiveUniformsiv(program, 1, &u, GL_UNIFORM_TYPE, &type);
    if (block < 0 && !is_opaque(GLenum(type))) {
      return make_error(ErrorCode::kInvalidArgument, "uniform " + uniform_name(program, u),
                        "lives outside a uniform block (looked up by name, unchecked)");
    }
  }
  return {};
}

size_t uniform_buffer_alignment() {
  GLint a = 0;
  glGetIntegerv(GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT, &a);
  return size_t(std::max(a, 16));
}

}  // namespace loam::gpu
