#include "client/render/patch_draw.h"

#include <algorithm>
#include <cmath>
#include <glm/gtc/type_ptr.hpp>

#include "client/terrain/height_source.h"
#include "gpu/shader_library.h"
#include "gpu/uniform_block.h"

namespace loam::render {

Result<gpu::GlProgram> build_patch_program(std::span<const std::string_view> vertex_files,
                                           std::span<const std::string_view> fragment_files,
                                           const std::function<Status(GLuint)>& extra_blocks) {
  auto program = gpu::build_graphics_program_from(vertex_files, fragment_files);
  if (!program) return program.error();
  LOAM_TRY(gpu::verify_uniform_block(program->get(), "GeomipmapFrame", sizeof(GeomipmapFrameBlock),
                                     kGeomipmapFrameMembers));
  if (extra_blocks) LOAM_TRY(extra_blocks(program->get()));
  LOAM_TRY(gpu::verify_no_loose_uniforms(program->get()));
  return std::move(*program);
}

WorldHeights WorldHeights::read(const terrain::HeightSource& source) {
  const WorldParams& p = source.params();
  WorldHeights w;
  w.rect = p.sample_rect();
  w.samples.resize(size_t(w.rect.area()));
  source.read(0, w.rect, w.samples);
  const auto [lo, hi] = std::minmax_element(w.samples.begin(), w.samples.end());
  w.min_height_m = double(*lo) * p.meters_per_unit;
  w.max_height_m = double(*hi) * p.meters_per_unit;
  return w;
}

std::vector<uint16_t> WorldHeights::refresh(const terrain::HeightSource& source, const RectI& r) {
  std::vector<uint16_t> fresh(size_t(r.area()));
  source.read(0, r, fresh);
  for (int64_t y = r.y0; y < r.y1; ++y) {
    std::copy_n(fresh.begin() + (y - r.y0) * r.width(), r.width(),
                samples.begin() + (y - rect.y0) * rect.width() + (r.x0 - rect.x0));
  }
  return fresh;
}

gpu::GlVertexArray make_patch_vertex_array() {
  GLuint vao = 0;
  glCreateVertexArrays(1, &vao);
  for (GLuint a = 0; a < 4; ++a) {
    glEnableVertexArrayAttrib(vao, a);
    glVertexArrayAttribBinding(vao, a, 0);
    if (a < 2) {
      glVertexArrayAttribIFormat(vao, a, 4, GL_INT, a * 16);
    } else {
      glVertexArrayAttribFormat(vao, a, 4, GL_FLOAT, GL_FALSE, a * 16);
    }
  }
  glVertexArrayBindingDivisor(vao, 0, 1);
  return gpu::GlVertexArray(vao);
}

PatchIndexBuffer::Range PatchIndexBuffer::get(const std::array<int8_t, 5>& key,
                                              const std::function<Triangles()>& build) {
  if (const auto it = ranges_.find(key); it != ranges_.end()) return it->second;
  const Triangles tris = build();
  Range r{uint32_t(data_.size()), uint32_t(tris.size() * 3)};
  for (const auto& t : tris) data_.insert(data_.end(), t.begin(), t.end());
  ranges_.emplace(key, r);
  const size_t bytes = data_.size() * sizeof(uint16_t);
  if (bytes > capacity_) {
    // Grow by doubling: variants are few (the levels and side combinations a view meets).
    capacity_ = std::max<size_t>(bytes * 2, 1 << 16);
    buffer_ = gpu::make_buffer();
    glNamedBufferStorage(buffer_.get(), GLsizeiptr(capacity_), nullptr, GL_DYNAMIC_STORAGE_BIT);
    glNamedBufferSubData(buffer_.get(), 0, GLsizeiptr(bytes), data_.data());
    glVertexArrayElementBuffer(vao_, buffer_.get());
  } else {
    glNamedBufferSubData(buffer_.get(), GLintptr(r.first * sizeof(uint16_t)),
                         GLsizeiptr(r.count * sizeof(uint16_t)), data_.data() + r.first);
  }
  return r;
}

void PatchInstanceBuffer::upload(const std::vector<PatchInstance>& instances) {
  const size_t bytes = instances.size() * sizeof(PatchInstance);
  if (bytes > capacity_) {
    capacity_ = std::max<size_t>(bytes * 3 / 2, 1 << 12);
    buffer_ = gpu::make_buffer();
    glNamedBufferStorage(buffer_.get(), GLsizeiptr(capacity_), nullptr, GL_DYNAMIC_STORAGE_BIT);
    glVertexArrayVertexBuffer(vao_, 0, buffer_.get(), 0, sizeof(PatchInstance));
  }
  if (bytes > 0) glNamedBufferSubData(buffer_.get(), 0, GLsizeiptr(bytes), instances.data());
}

GeomipmapFrameBlock patch_frame(const glm::mat4& view_proj, std::array<int32_t, 4> grid,
                                double meters_per_sample, double meters_per_unit, double height_offset,
                                const scene::Camera& camera, double min_height_m, double max_height_m) {
  GeomipmapFrameBlock f{};
  std::copy_n(glm::value_ptr(view_proj), 16, f.view_proj);
  std::copy(grid.begin(), grid.end(), f.grid);
  f.scale[0] = float(meters_per_sample), f.scale[1] = float(meters_per_unit);
  f.scale[2] = float(height_offset - camera.z);
  const float az = glm::radians(135.0f), el = glm::radians(35.0f);
  f.sun[0] = std::sin(az) * std::cos(el), f.sun[1] = std::cos(az) * std::cos(el), f.sun[2] = std::sin(el);
  f.height_range[0] = float(min_height_m), f.height_range[1] = float(max_height_m);
  return f;
}

}  // namespace loam::render
