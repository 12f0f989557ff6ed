#include "bench/lod/geomipmap_renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <glm/gtc/type_ptr.hpp>

#include "client/render/patch_draw.h"
#include "client/render/reversed_depth.h"
#include "client/scene/frustum.h"
#include "gpu/shader_library.h"

namespace loam::render {

Result<std::unique_ptr<GeomipmapRenderer>> GeomipmapRenderer::create(const terrain::HeightSource& source,
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
  r->heights_ = WorldHeights::read(source);
  r->errors_ = lod::GeomipmapErrors::compute(r->grid_, r->heights_.grid());

  r->texture_ = gpu::make_texture(GL_TEXTURE_2D);
  glTextureStorage2D(r->texture_.get(), 1, GL_R16UI, GLsizei(r->world_.width()), GLsizei(r->world_.height()));
  glTextureParameteri(r->texture_.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(r->texture_.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage2D(r->texture_.get(), 0, 0, 0, GLsizei(r->world_.width()), GLsizei(r->world_.height()),
                      GL_RED_INTEGER, GL_UNSIGNED_SHORT, r->heights_.samples.data());

  const std::string_view vertex[] = {"geomipmap_blocks.glsl", "patch_morph.glsl", "geomipmap.vert.glsl"};
  auto program = build_patch_program(vertex);
  if (!program) return program.error();
  r->program_ = std::move(*program);
  r->frame_block_.emplace(1);
  r->vao_ = make_patch_vertex_array();
  r->indices_.emplace(r->vao_.get());
  r->instances_.emplace(r->vao_.get());
  return r;
}

GeomipmapFrameStats GeomipmapRenderer::render(const scene::Camera& camera, int32_t width, int32_t height) {
  const double select_ms = select(camera, height);
  GeomipmapFrameStats stats = draw(camera, width, height);
  stats.cpu_ms += select_ms;
  return stats;
}

double GeomipmapRenderer::select(const scene::Camera& lod_camera, int32_t viewport_height) {
  const auto t0 = std::chrono::steady_clock::now();
  const double mps = scale_.meters_per_sample;
  lod::LodView view;
  view.x = lod_camera.x - double(world_.x0) * mps;
  view.y = lod_camera.y - double(world_.y0) * mps;
  view.z = lod_camera.z;
  view.pixels_per_radian = lod::pixels_per_radian(viewport_height, lod_camera.fov_y_degrees);
  view.tolerance_px = config_.tolerance_px;
  lods_ = lod::select_lods(grid_, errors_, scale_, view, config_.morph && config_.tolerance_px > 0);
  if (config_.skirts) {
    lod::assign_own_sides(lods_);
    skirt_depths_ = lod::skirt_depths(grid_, errors_, lods_);
  }
  return ms_since(t0);
}

GeomipmapFrameStats GeomipmapRenderer::draw(const scene::Camera& camera, int32_t width, int32_t height) {
  GeomipmapFrameStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  const double mps = scale_.meters_per_sample;
  const glm::mat4 vp = scene::view_projection(camera, width, height);
  const scene::Frustum frustum = scene::frustum_of(vp);
  const int32_t c = grid_.cells();
  std::vector<PatchInstance> instances;
  std::vector<PatchIndexBuffer::Range> draws;
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
        if (scene::box_outside(frustum, lo, hi)) {
          ++stats.patches_culled;
          continue;
        }
      }
      PatchInstance in{};
      in.patch[0] = int32_t(ox), in.patch[1] = int32_t(oy), in.patch[2] = lod.level;
      for (size_t k = 0; k < 4; ++k)
        in.edge_level[k] = lod.edge_level[k], in.edge_morph[k] = lod.edge_morph[k];
      in.misc[0] = lod.morph, in.misc[1] = float(rel_x), in.misc[2] = float(rel_y);
      instances.push_back(in);
      if (config_.skirts)
        in.patch[3] = int32_t(skirt_depths_[size_t(py) * size_t(grid_.patches_x) + size_t(px)]);
      // With skirts, a patch's sides are its own level's: the key's high bit marks the skirt.
      const std::array<int8_t, 5> key{int8_t(lod.level | (config_.skirts ? 0x40 : 0)), lod.edge_level[0],
                                      lod.edge_level[1], lod.edge_level[2], lod.edge_level[3]};
      draws.push_back(indices_->get(key, [&] {
        auto tris = lod::patch_triangles(grid_, lod.level, lod.edge_level);
        if (config_.skirts) {
          const auto skirt = lod::skirt_triangles(grid_, lod.level);
          tris.insert(tris.end(), skirt.begin(), skirt.end());
        }
        return tris;
      }));
    }
  }
  instances_->upload(instances);
  const GeomipmapFrameBlock f = patch_frame(
      vp, {grid_.patch_size, grid_.levels, int32_t(world_.width()), int32_t(world_.height())}, mps,
      scale_.meters_per_unit, scale_.height_offset, camera, heights_.min_height_m, heights_.max_height_m);
  frame_block_->write(0, f);
  stats.cpu_ms = ms_since(t0);

  frame_block_->bind(0);
  glUseProgram(program_.get());
  glBindVertexArray(vao_.get());
  glBindTextureUnit(0, texture_.get());
  const ReversedDepthTest depth_test;
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
  const std::vector<uint16_t> fresh = heights_.refresh(*source_, r);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage2D(texture_.get(), 0, GLint(r.x0 - world_.x0), GLint(r.y0 - world_.y0), GLsizei(r.width()),
                      GLsizei(r.height()), GL_RED_INTEGER, GL_UNSIGNED_SHORT, fresh.data());
  const RectI local{r.x0 - world_.x0, r.y0 - world_.y0, r.x1 - world_.x0, r.y1 - world_.y0};
  u.patches = int32_t(errors_.update(grid_, heights_.grid(), local).size());
  u.cpu_ms = ms_since(t0);
  return u;
}

size_t GeomipmapRenderer::gpu_bytes() const {
  return heights_.samples.size() * sizeof(uint16_t) + indices_->bytes() + instances_->bytes();
}

}  // namespace loam::render
