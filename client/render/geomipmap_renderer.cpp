#include "client/render/geomipmap_renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <glm/gtc/type_ptr.hpp>

#include "client/render/frustum.h"
#include "gpu/shader_library.h"

namespace loam::render {

namespace {

// Per patch, the instanced attributes of shaders/geomipmap.vert.glsl.
struct Instance {
  int32_t patch[4];  // origin (grid samples), level, -
  int32_t edge_level[4];
  float edge_morph[4];
  float misc[4];  // morph, origin relative to the camera (render frame x, y), -
};
static_assert(sizeof(Instance) == 64);

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

Result<std::unique_ptr<GeomipmapRenderer>> GeomipmapRenderer::create(const HeightSource& source,
                                                                     const GeomipmapConfig& config) {
  const WorldParams& p = source.params();
  std::unique_ptr<GeomipmapRenderer> r(new GeomipmapRenderer());
  r->source_ = &source;
  r->config_ = config;
  r->world_ = p.sample_rect();
  auto grid = lod::GeomipmapGrid::make(r->world_.width(), r->world_.height(), config.patch_size);
  if (!grid) return grid.error();
  r->grid_ = *grid;
  GLint max_size = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  if (r->world_.width() > max_size || r->world_.height() > max_size) {
    return make_error(ErrorCode::kOversize, "geomipmap.world",
                      "the world is wider than GL_MAX_TEXTURE_SIZE (" + std::to_string(max_size) + ")");
  }
  r->scale_ = {p.meters_per_sample, p.meters_per_unit, p.height_offset};
  r->heights_.resize(size_t(r->world_.area()));
  source.read(0, r->world_, r->heights_);
  const auto [lo, hi] = std::minmax_element(r->heights_.begin(), r->heights_.end());
  r->min_height_m_ = double(*lo) * p.meters_per_unit;
  r->max_height_m_ = double(*hi) * p.meters_per_unit;
  r->errors_ = lod::GeomipmapErrors::compute(r->grid_, {r->heights_, r->world_.width(), r->world_.height()});

  r->texture_ = gpu::make_texture(GL_TEXTURE_2D);
  glTextureStorage2D(r->texture_.get(), 1, GL_R16UI, GLsizei(r->world_.width()), GLsizei(r->world_.height()));
  glTextureParameteri(r->texture_.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(r->texture_.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage2D(r->texture_.get(), 0, 0, 0, GLsizei(r->world_.width()), GLsizei(r->world_.height()),
                      GL_RED_INTEGER, GL_UNSIGNED_SHORT, r->heights_.data());

  const std::string_view vertex[] = {"geomipmap_blocks.glsl", "geomipmap.vert.glsl"};
  const std::string_view fragment[] = {"geomipmap_blocks.glsl", "geomipmap.frag.glsl"};
  auto program = gpu::build_graphics_program_from(vertex, fragment);
  if (!program) return program.error();
  r->program_ = std::move(*program);
  LOAM_TRY(gpu::verify_uniform_block(r->program_.get(), "GeomipmapFrame", sizeof(GeomipmapFrameBlock),
                                     kGeomipmapFrameMembers));
  LOAM_TRY(gpu::verify_no_loose_uniforms(r->program_.get()));
  r->frame_block_.emplace(1);

  GLuint vao = 0;
  glCreateVertexArrays(1, &vao);
  r->vao_ = gpu::GlVertexArray(vao);
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
  return r;
}

GeomipmapRenderer::Variant GeomipmapRenderer::variant(const lod::PatchLod& lod) {
  const std::array<int8_t, 5> key{lod.level, lod.edge_level[0], lod.edge_level[1], lod.edge_level[2],
                                  lod.edge_level[3]};
  if (const auto it = variants_.find(key); it != variants_.end()) return it->second;
  const auto tris = lod::patch_triangles(grid_, lod.level, lod.edge_level);
  Variant v{uint32_t(index_data_.size()), uint32_t(tris.size() * 3)};
  for (const auto& t : tris) index_data_.insert(index_data_.end(), t.begin(), t.end());
  variants_.emplace(key, v);
  const size_t bytes = index_data_.size() * sizeof(uint16_t);
  if (bytes > index_capacity_) {
    // Grow by doubling: variants are few (the levels and side combinations a view meets).
    index_capacity_ = std::max<size_t>(bytes * 2, 1 << 16);
    indices_ = gpu::make_buffer();
    glNamedBufferStorage(indices_.get(), GLsizeiptr(index_capacity_), nullptr, GL_DYNAMIC_STORAGE_BIT);
    glNamedBufferSubData(indices_.get(), 0, GLsizeiptr(bytes), index_data_.data());
    glVertexArrayElementBuffer(vao_.get(), indices_.get());
  } else {
    glNamedBufferSubData(indices_.get(), GLintptr(v.first * sizeof(uint16_t)),
                         GLsizeiptr(v.count * sizeof(uint16_t)), index_data_.data() + v.first);
  }
  return v;
}

GeomipmapFrameStats GeomipmapRenderer::render(const Camera& camera, int32_t width, int32_t height) {
  const double select_ms = select(camera, height);
  GeomipmapFrameStats stats = draw(camera, width, height);
  stats.cpu_ms += select_ms;
  return stats;
}

double GeomipmapRenderer::select(const Camera& lod_camera, int32_t viewport_height) {
  const auto t0 = std::chrono::steady_clock::now();
  const double mps = scale_.meters_per_sample;
  lod::LodView view;
  view.x = lod_camera.x - double(world_.x0) * mps;
  view.y = lod_camera.y - double(world_.y0) * mps;
  view.z = lod_camera.z;
  view.pixels_per_radian = lod::pixels_per_radian(viewport_height, lod_camera.fov_y_degrees);
  view.tolerance_px = config_.tolerance_px;
  lods_ = lod::select_lods(grid_, errors_, scale_, view, config_.morph && config_.tolerance_px > 0);
  return ms_since(t0);
}

GeomipmapFrameStats GeomipmapRenderer::draw(const Camera& camera, int32_t width, int32_t height) {
  GeomipmapFrameStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  const double mps = scale_.meters_per_sample;
  const glm::mat4 vp = view_projection(camera, width, height);
  const Frustum frustum = frustum_of(vp);
  const int32_t c = grid_.cells();
  std::vector<Instance> instances;
  std::vector<Variant> draws;
  instances.reserve(lods_.size());
  for (int32_t py = 0; py < grid_.patches_y; ++py) {
    for (int32_t px = 0; px < grid_.patches_x; ++px) {
      const lod::PatchLod& lod = lods_[size_t(py) * size_t(grid_.patches_x) + size_t(px)];
      const int64_t ox = int64_t(px) * c, oy = int64_t(py) * c;
      const double rel_x = double(world_.x0 + ox) * mps - camera.x;
      const double rel_y = -(double(world_.y0 + oy) * mps - camera.y);
      if (config_.cull) {
        const double w = double(c) * mps, h = double(c) * mps;
        const glm::vec3 lo(float(rel_x), float(rel_y - h),
                           float(scale_.meters(errors_.min_height(px, py)) - camera.z));
        const glm::vec3 hi(float(rel_x + w), float(rel_y),
                           float(scale_.meters(errors_.max_height(px, py)) - camera.z));
        if (box_outside(frustum, lo, hi)) {
          ++stats.patches_culled;
          continue;
        }
      }
      Instance in{};
      in.patch[0] = int32_t(ox), in.patch[1] = int32_t(oy), in.patch[2] = lod.level;
      for (size_t k = 0; k < 4; ++k)
        in.edge_level[k] = lod.edge_level[k], in.edge_morph[k] = lod.edge_morph[k];
      in.misc[0] = lod.morph, in.misc[1] = float(rel_x), in.misc[2] = float(rel_y);
      instances.push_back(in);
      draws.push_back(variant(lod));
    }
  }
  const size_t bytes = instances.size() * sizeof(Instance);
  if (bytes > instance_capacity_) {
    instance_capacity_ = std::max(bytes, size_t(grid_.patch_count()) * sizeof(Instance));
    instances_ = gpu::make_buffer();
    glNamedBufferStorage(instances_.get(), GLsizeiptr(instance_capacity_), nullptr, GL_DYNAMIC_STORAGE_BIT);
    glVertexArrayVertexBuffer(vao_.get(), 0, instances_.get(), 0, sizeof(Instance));
  }
  if (bytes > 0) glNamedBufferSubData(instances_.get(), 0, GLsizeiptr(bytes), instances.data());

  GeomipmapFrameBlock f{};
  std::copy_n(glm::value_ptr(vp), 16, f.view_proj);
  f.grid[0] = grid_.patch_size, f.grid[1] = grid_.levels;
  f.grid[2] = int32_t(world_.width()), f.grid[3] = int32_t(world_.height());
  f.scale[0] = float(mps), f.scale[1] = float(scale_.meters_per_unit);
  f.scale[2] = float(scale_.height_offset - camera.z);
  const float az = glm::radians(135.0f), el = glm::radians(35.0f);
  f.sun[0] = std::sin(az) * std::cos(el), f.sun[1] = std::cos(az) * std::cos(el), f.sun[2] = std::sin(el);
  f.height_range[0] = float(min_height_m_), f.height_range[1] = float(max_height_m_);
  frame_block_->write(0, f);
  stats.cpu_ms = ms_since(t0);

  frame_block_->bind(0);
  glUseProgram(program_.get());
  glBindVertexArray(vao_.get());
  glBindTextureUnit(0, texture_.get());
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glViewport(0, 0, width, height);
  for (size_t i = 0; i < draws.size(); ++i) {
    glDrawElementsInstancedBaseInstance(
        GL_TRIANGLES, GLsizei(draws[i].count), GL_UNSIGNED_SHORT,
        reinterpret_cast<const void*>(uintptr_t(draws[i].first) * sizeof(uint16_t)), 1, GLuint(i));
    stats.triangles += draws[i].count / 3;
  }
  stats.draw_calls = int32_t(draws.size());
  glBindVertexArray(0);
  glUseProgram(0);
  return stats;
}

GeomipmapUpdate GeomipmapRenderer::invalidate(const RectI& mip0_rect) {
  GeomipmapUpdate u;
  const RectI r = mip0_rect.intersect(world_);
  if (r.empty()) return u;
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<uint16_t> fresh(size_t(r.area()));
  source_->read(0, r, fresh);
  for (int64_t y = r.y0; y < r.y1; ++y) {
    std::copy_n(fresh.begin() + (y - r.y0) * r.width(), r.width(),
                heights_.begin() + (y - world_.y0) * world_.width() + (r.x0 - world_.x0));
  }
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage2D(texture_.get(), 0, GLint(r.x0 - world_.x0), GLint(r.y0 - world_.y0), GLsizei(r.width()),
                      GLsizei(r.height()), GL_RED_INTEGER, GL_UNSIGNED_SHORT, fresh.data());
  const RectI local{r.x0 - world_.x0, r.y0 - world_.y0, r.x1 - world_.x0, r.y1 - world_.y0};
  u.patches = int32_t(errors_.update(grid_, {heights_, world_.width(), world_.height()}, local).size());
  u.cpu_ms = ms_since(t0);
  return u;
}

size_t GeomipmapRenderer::gpu_bytes() const {
  return heights_.size() * sizeof(uint16_t) + index_capacity_ + instance_capacity_;
}

}  // namespace loam::render
