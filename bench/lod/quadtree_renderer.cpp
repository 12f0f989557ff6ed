#include "bench/lod/quadtree_renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <glm/gtc/type_ptr.hpp>

#include "client/render/reversed_depth.h"
#include "client/scene/frustum.h"
#include "gpu/shader_library.h"

namespace loam::render {

Result<std::unique_ptr<QuadtreeRenderer>> QuadtreeRenderer::create(const terrain::HeightSource& source,
                                                                   const QuadtreeConfig& config) {
  const WorldParams& p = source.params();
  std::unique_ptr<QuadtreeRenderer> r(new QuadtreeRenderer());
  r->source_ = &source;
  r->config_ = config;
  r->world_ = p.sample_rect();
  auto grid = lod::QuadtreeGrid::make(r->world_.width(), r->world_.height(), config.block_size);
  if (!grid) return grid.error();
  r->grid_ = *grid;
  r->grid_.independent_blocks = config.skirts;
  r->scale_ = {p.meters_per_sample, p.meters_per_unit, p.height_offset};
  r->heights_ = WorldHeights::read(source);
  r->errors_ = lod::QuadtreeErrors::compute(r->grid_, r->heights_.grid());
  r->state_.emplace(r->grid_);
  const size_t blocks = size_t(r->grid_.blocks_x) * size_t(r->grid_.blocks_y);
  r->stale_.assign(blocks, 1);
  r->blocks_.resize(blocks);

  const std::string_view vertex[] = {"geomipmap_blocks.glsl", "quadtree.vert.glsl"};
  auto program = build_patch_program(vertex);
  if (!program) return program.error();
  r->program_ = std::move(*program);
  r->frame_block_.emplace(1);

  GLuint vao = 0;
  glCreateVertexArrays(1, &vao);
  r->vao_ = gpu::GlVertexArray(vao);
  glEnableVertexArrayAttrib(vao, 0);
  glVertexArrayAttribBinding(vao, 0, 0);
  glVertexArrayAttribFormat(vao, 0, 3, GL_FLOAT, GL_FALSE, 0);
  glEnableVertexArrayAttrib(vao, 1);
  glVertexArrayAttribBinding(vao, 1, 1);
  glVertexArrayAttribFormat(vao, 1, 2, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayBindingDivisor(vao, 1, 1);
  r->origins_ = gpu::make_buffer();
  glNamedBufferStorage(r->origins_.get(), GLsizeiptr(blocks * 2 * sizeof(float)), nullptr,
                       GL_DYNAMIC_STORAGE_BIT);
  glVertexArrayVertexBuffer(vao, 1, r->origins_.get(), 0, 2 * sizeof(float));
  return r;
}

void QuadtreeRenderer::rebuild(int32_t bx, int32_t by) {
  const size_t k = size_t(by) * size_t(grid_.blocks_x) + size_t(bx);
  lod::block_mesh(grid_, heights_.grid(), *state_, bx, by, vertex_scratch_, triangle_scratch_,
                  config_.skirts ? skirt_depths_[k] : 0.0f);
  std::vector<float> v(vertex_scratch_.size() * 3);
  for (size_t i = 0; i < vertex_scratch_.size(); ++i) {
    v[3 * i] = float(vertex_scratch_[i].x), v[3 * i + 1] = float(vertex_scratch_[i].y);
    v[3 * i + 2] = vertex_scratch_[i].height;
  }
  Block& b = blocks_[size_t(by) * size_t(grid_.blocks_x) + size_t(bx)];
  if (!b.vertices) b.vertices = gpu::make_buffer(), b.indices = gpu::make_buffer();
  glNamedBufferData(b.vertices.get(), GLsizeiptr(v.size() * sizeof(float)), v.data(), GL_DYNAMIC_DRAW);
  glNamedBufferData(b.indices.get(), GLsizeiptr(triangle_scratch_.size() * sizeof(triangle_scratch_[0])),
                    triangle_scratch_.data(), GL_DYNAMIC_DRAW);
  b.index_count = uint32_t(triangle_scratch_.size() * 3);
}

QuadtreeFrameStats QuadtreeRenderer::render(const scene::Camera& camera, int32_t width, int32_t height) {
  QuadtreeFrameStats s = select(camera, height);
  const QuadtreeFrameStats d = draw(camera, width, height);
  s.triangles = d.triangles, s.draw_calls = d.draw_calls, s.blocks_culled = d.blocks_culled;
  s.cpu_ms += d.cpu_ms;
  return s;
}

QuadtreeFrameStats QuadtreeRenderer::select(const scene::Camera& lod_camera, int32_t viewport_height) {
  QuadtreeFrameStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  const double mps = scale_.meters_per_sample;
  lod::LodView view;
  view.x = lod_camera.x - double(world_.x0) * mps;
  view.y = lod_camera.y - double(world_.y0) * mps;
  view.z = lod_camera.z;
  view.pixels_per_radian = lod::pixels_per_radian(viewport_height, lod_camera.fov_y_degrees);
  view.tolerance_px = config_.tolerance_px;
  const lod::QuadtreeSelectStats st =
      lod::select_quadtree(grid_, errors_, scale_, view, *state_, config_.morph);
  stats.squares_tested = st.squares_tested;
  if (config_.skirts) {
    // A block whose skirt depth moved is rebuilt with it.
    std::vector<float> depths = lod::quadtree_skirt_depths(grid_, errors_, *state_);
    for (size_t i = 0; i < depths.size(); ++i)
      if (skirt_depths_.size() != depths.size() || skirt_depths_[i] != depths[i]) stale_[i] = 1;
    skirt_depths_ = std::move(depths);
  }
  const auto& changed = state_->changed_blocks();
  for (int32_t by = 0; by < grid_.blocks_y; ++by) {
    for (int32_t bx = 0; bx < grid_.blocks_x; ++bx) {
      const size_t i = size_t(by) * size_t(grid_.blocks_x) + size_t(bx);
      if (!changed[i] && !stale_[i]) continue;
      rebuild(bx, by);
      ++stats.blocks_rebuilt;
    }
  }
  state_->clear_changed();
  std::fill(stale_.begin(), stale_.end(), 0);
  stats.cpu_ms = ms_since(t0);
  return stats;
}

QuadtreeFrameStats QuadtreeRenderer::draw(const scene::Camera& camera, int32_t width, int32_t height) {
  QuadtreeFrameStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  const double mps = scale_.meters_per_sample;
  const glm::mat4 vp = scene::view_projection(camera, width, height);
  const scene::Frustum frustum = scene::frustum_of(vp);
  const int32_t b = grid_.block_size;
  std::vector<float> origins;
  std::vector<size_t> visible;
  for (int32_t by = 0; by < grid_.blocks_y; ++by) {
    for (int32_t bx = 0; bx < grid_.blocks_x; ++bx) {
      const double rel_x = double(world_.x0 + int64_t(bx) * b) * mps - camera.x;
      const double rel_y = -(double(world_.y0 + int64_t(by) * b) * mps - camera.y);
      if (config_.cull) {
        const int32_t l = grid_.levels;
        const glm::vec3 lo(float(rel_x), float(rel_y - b * mps),
                           float(scale_.meters(errors_.min_height(l, bx, by)) - camera.z));
        const glm::vec3 hi(float(rel_x + b * mps), float(rel_y),
                           float(scale_.meters(errors_.max_height(l, bx, by)) - camera.z));
        if (scene::box_outside(frustum, lo, hi)) {
          ++stats.blocks_culled;
          continue;
        }
      }
      origins.push_back(float(rel_x));
      origins.push_back(float(rel_y));
      visible.push_back(size_t(by) * size_t(grid_.blocks_x) + size_t(bx));
    }
  }
  if (!origins.empty())
    glNamedBufferSubData(origins_.get(), 0, GLsizeiptr(origins.size() * sizeof(float)), origins.data());
  const GeomipmapFrameBlock f = patch_frame(
      vp, {grid_.block_size + 1, grid_.levels, int32_t(world_.width()), int32_t(world_.height())}, mps,
      scale_.meters_per_unit, scale_.height_offset, camera, heights_.min_height_m, heights_.max_height_m);
  frame_block_->write(0, f);
  stats.cpu_ms = ms_since(t0);

  frame_block_->bind(0);
  glUseProgram(program_.get());
  glBindVertexArray(vao_.get());
  const ReversedDepthTest depth_test;
  glViewport(0, 0, width, height);
  for (size_t k = 0; k < visible.size(); ++k) {
    const Block& blk = blocks_[visible[k]];
    if (blk.index_count == 0) continue;
    glVertexArrayVertexBuffer(vao_.get(), 0, blk.vertices.get(), 0, 3 * sizeof(float));
    glVertexArrayElementBuffer(vao_.get(), blk.indices.get());
    glDrawElementsInstancedBaseInstance(GL_TRIANGLES, GLsizei(blk.index_count), GL_UNSIGNED_INT, nullptr, 1,
                                        GLuint(k));
    stats.triangles += blk.index_count / 3;
    ++stats.draw_calls;
  }
  glBindVertexArray(0);
  glUseProgram(0);
  return stats;
}

int64_t QuadtreeRenderer::invalidate(const RectI& mip0_rect) {
  const RectI r = mip0_rect.intersect(world_);
  if (r.empty()) return 0;
  heights_.refresh(*source_, r);
  const RectI local{r.x0 - world_.x0, r.y0 - world_.y0, r.x1 - world_.x0, r.y1 - world_.y0};
  const int64_t n = errors_.update(grid_, heights_.grid(), local);
  // Blocks holding a changed sample, or a vertex whose morph target reads one, are rebuilt.
  const int64_t bs = grid_.block_size;
  for (int64_t by = std::max<int64_t>(0, floor_div(local.y0 - bs, bs));
       by <= std::min<int64_t>(grid_.blocks_y - 1, floor_div(local.y1 + bs, bs)); ++by)
    for (int64_t bx = std::max<int64_t>(0, floor_div(local.x0 - bs, bs));
         bx <= std::min<int64_t>(grid_.blocks_x - 1, floor_div(local.x1 + bs, bs)); ++bx)
      stale_[size_t(by) * size_t(grid_.blocks_x) + size_t(bx)] = 1;
  return n;
}

}  // namespace loam::render
