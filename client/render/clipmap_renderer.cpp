#include "client/render/clipmap_renderer.h"

#include <algorithm>
#include <array>
#include <bit>
#include <climits>
#include <cmath>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <string>

#include "client/render/clipmap_blocks.h"
#include "client/render/reversed_depth.h"
#include "client/render/toroidal_upload.h"
#include "client/scene/frustum.h"
#include "client/scene/sun_shadow.h"
#include "gpu/shader_library.h"

namespace loam::render {

namespace {

// The uniform buffer binding points of shaders/clipmap_blocks.glsl.
constexpr GLuint kFrameBinding = 0, kLevelBinding = 1;

void put(float* out, const glm::vec2& v) { out[0] = v.x, out[1] = v.y; }

// Level samples whose mip-0 sample (i * s) lies in [x0, x1): [ceil(x0 / s), ceil(x1 / s)).
RectI in_level_grid(const RectI& mip0, int64_t s) {
  return {ceil_div(mip0.x0, s), ceil_div(mip0.y0, s), ceil_div(mip0.x1, s), ceil_div(mip0.y1, s)};
}

}  // namespace

Result<std::unique_ptr<ClipmapRenderer>> ClipmapRenderer::create(const terrain::HeightSource& source,
                                                                 const RendererConfig& config) {
  auto mesh = lod::ClipmapMesh::build(config.n);
  if (!mesh) return mesh.error();
  std::unique_ptr<ClipmapRenderer> r(new ClipmapRenderer());
  r->source_ = &source;
  r->config_ = config;
  const WorldParams& p = source.params();
  r->levels_ = config.levels > 0
                   ? config.levels
                   : lod::levels_for_view_distance(config.n, p.meters_per_sample, config.view_distance);
  if (r->levels_ < 1 || r->levels_ > lod::kMaxClipmapLevels) {
    return make_error(ErrorCode::kInvalidArgument, "clipmap.levels",
                      "must be 1.." + std::to_string(lod::kMaxClipmapLevels));
  }
  // A level holds a region of n + 2 * kLevelPad samples in a torus of the next power of two:
  // the far-origin shift (a multiple of 2^L tiles) is then a multiple of the torus, so a
  // level's texels, and the filtered normal lookups, are the same at home and far away.
  r->region_size_ = config.n + 2 * kLevelPad;
  r->tex_size_ = int32_t(std::bit_ceil(uint32_t(r->region_size_)));
  r->mesh_ = std::move(*mesh);
  if (config.min_height_m >= config.max_height_m) {
    const auto [lo, hi] = terrain::coarsest_height_range_m(source);
    r->config_.min_height_m = lo;
    r->config_.max_height_m = hi;
  }
  auto integer_texture = [](GLenum format, int32_t size) {
    gpu::GlTexture t = gpu::make_texture(GL_TEXTURE_2D);
    glTextureStorage2D(t.get(), 1, format, size, size);
    // An integer texture with the default mipmapped min filter is incomplete and reads 0.
    glTextureParameteri(t.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(t.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    return t;
  };
  for (int32_t l = 0; l < r->levels_; ++l) {
    Level level;
    level.texture = integer_texture(GL_R16UI, r->tex_size_);
    level.normals = gpu::make_texture(GL_TEXTURE_2D);
    glTextureStorage2D(level.normals.get(), 1, GL_RG16_SNORM, r->tex_size_, r->tex_size_);
    // Filtered, and wrapping: the level is toroidal, so GL_REPEAT joins its seams.
    glTextureParameteri(level.normals.get(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(level.normals.get(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(level.normals.get(), GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTextureParameteri(level.normals.get(), GL_TEXTURE_WRAP_T, GL_REPEAT);
    if (config.look.materials) {
      level.change = gpu::make_texture(GL_TEXTURE_2D);
      glTextureStorage2D(level.change.get(), 1, GL_R16F, r->tex_size_, r->tex_size_);
      glTextureParameteri(level.change.get(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTextureParameteri(level.change.get(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      glTextureParameteri(level.change.get(), GL_TEXTURE_WRAP_S, GL_REPEAT);
      glTextureParameteri(level.change.get(), GL_TEXTURE_WRAP_T, GL_REPEAT);
      const float zero = 0.0f;
      glClearTexImage(level.change.get(), 0, GL_RED, GL_FLOAT, &zero);
    }
    level.mirror.assign(size_t(r->tex_size_) * size_t(r->tex_size_), 0);
    level.world = in_level_grid(p.sample_rect(), int64_t(1) << l);
    r->level_.push_back(std::move(level));
  }
  // A power of two, like the level tori (see region_size_): far-origin shifts are multiples.
  auto detail = DetailRegion::create_unless_zero(config.detail_size);
  if (!detail) return detail.error();
  r->detail_ = std::move(*detail);
  auto look = TerrainLook::create(config.look);
  if (!look) return look.error();
  r->look_.emplace(std::move(*look));
  auto normal_pass = gpu::LevelNormalPass::create();
  if (!normal_pass) return normal_pass.error();
  r->normal_pass_.emplace(std::move(*normal_pass));
  r->indices_ = gpu::make_buffer();
  const auto& idx = r->mesh_->indices();
  glNamedBufferStorage(r->indices_.get(), GLsizeiptr(idx.size() * sizeof(uint32_t)), idx.data(), 0);
  GLuint vao = 0;
  glCreateVertexArrays(1, &vao);
  r->vao_ = gpu::GlVertexArray(vao);
  glVertexArrayElementBuffer(vao, r->indices_.get());
  const std::string_view vertex[] = {"clipmap_blocks.glsl", "terrain_shading_block.glsl",
                                     "clipmap.vert.glsl"};
  const std::string_view fragment[] = {"clipmap_blocks.glsl", "terrain_shading_block.glsl",
                                       "terrain_shading.glsl", "clipmap.frag.glsl"};
  auto program = gpu::build_graphics_program_from(vertex, fragment);
  if (!program) return program.error();
  r->program_ = std::move(*program);
  // Every uniform the draw sets is checked here, by name and offset, once.
  LOAM_TRY(gpu::verify_uniform_block(r->program_.get(), "ClipmapFrame", sizeof(ClipmapFrameBlock),
                                     kClipmapFrameMembers));
  LOAM_TRY(gpu::verify_uniform_block(r->program_.get(), "ClipmapLevel", sizeof(ClipmapLevelBlock),
                                     kClipmapLevelMembers));
  LOAM_TRY(TerrainLook::verify(r->program_.get()));
  LOAM_TRY(gpu::verify_no_loose_uniforms(r->program_.get()));
  if (config.look.shadows) {
    const std::string_view shadow_fragment[] = {"clipmap_blocks.glsl", "terrain_shading_block.glsl",
                                                "shadow_depth.frag.glsl"};
    auto shadow = gpu::build_graphics_program_from(vertex, shadow_fragment);
    if (!shadow) return shadow.error();
    r->shadow_program_ = std::move(*shadow);
  }
  r->frame_block_.emplace(2);  // the view, and the sun's view for the shadow pass
  r->level_block_.emplace(r->levels_);
  return r;
}

std::array<double, 2> ClipmapRenderer::lod_center_samples(const scene::Camera& camera) const {
  const double mps = source_->params().meters_per_sample;
  const auto c = camera.lod_center.value_or(std::array<double, 2>{camera.x, camera.y});
  return {c[0] / mps, c[1] / mps};
}

int64_t ClipmapRenderer::upload(Level& level, int32_t mip, const RectI& rect) {
  const int64_t n = tex_size_;
  return for_each_torus_piece(rect, n, [&](const RectI& piece, int64_t tx, int64_t ty) {
    const int64_t w = piece.width(), h = piece.height();
    scratch_.resize(size_t(piece.area()));
    source_->read(mip, piece, scratch_);
    glTextureSubImage2D(level.texture.get(), 0, GLint(tx), GLint(ty), GLsizei(w), GLsizei(h), GL_RED_INTEGER,
                        GL_UNSIGNED_SHORT, scratch_.data());
    if (level.change) {
      change_scratch_.resize(size_t(piece.area()));
      if (source_->read_change(mip, piece, change_scratch_)) {
        change_known_ = true;
      } else {
        std::fill(change_scratch_.begin(), change_scratch_.end(), 0.0f);
      }
      glTextureSubImage2D(level.change.get(), 0, GLint(tx), GLint(ty), GLsizei(w), GLsizei(h), GL_RED,
                          GL_FLOAT, change_scratch_.data());
    }
    for (int64_t j = 0; j < h; ++j) {
      std::copy_n(scratch_.begin() + j * w, w, level.mirror.begin() + (ty + j) * n + tx);
    }
  });
}

void ClipmapRenderer::update_normals(int32_t l, const RectI& uploaded) {
  const Level& level = level_[size_t(l)];
  // Normals depend on heights up to 4 samples away (the one-sided stencils at the world's
  // edges), so they are computed where every stencil stays in the region: 4 samples in, which
  // still covers every vertex (kLevelPad = 5) and the sample after it that filtering reads.
  static_assert(kLevelPad >= 5);
  const RectI region{level.region_x + 4, level.region_y + 4, level.region_x + region_size_ - 4,
                     level.region_y + region_size_ - 4};
  const RectI r = RectI{uploaded.x0 - 4, uploaded.y0 - 4, uploaded.x1 + 4, uploaded.y1 + 4}.intersect(region);
  const WorldParams& p = source_->params();
  normal_pass_->update(level.texture.get(), level.normals.get(), tex_size_, level_region(l), r, level.world,
                       p, p.meters_per_sample * double(int64_t(1) << l));
}

int64_t ClipmapRenderer::update_levels(const scene::Camera& camera) {
  const auto c = lod_center_samples(camera);
  placed_ = lod::place_levels(config_.n, levels_, c[0], c[1]);
  int64_t texels = 0;
  for (int32_t l = 0; l < levels_; ++l) {
    Level& level = level_[size_t(l)];
    const int64_t rx = (placed_[size_t(l)].origin_x >> l) - kLevelPad;
    const int64_t ry = (placed_[size_t(l)].origin_y >> l) - kLevelPad;
    std::optional<std::array<int64_t, 2>> old;
    if (level.valid) old = std::array<int64_t, 2>{level.region_x, level.region_y};
    const std::vector<RectI> strips = lod::toroidal_strips(old, {rx, ry}, region_size_);
    level.valid = true;
    level.region_x = rx;
    level.region_y = ry;
    for (const RectI& s : strips) texels += upload(level, l, s);
    for (const RectI& s : strips) update_normals(l, s);
  }
  if (detail_) texels += detail_->update(*source_, c[0], c[1]);
  return texels;
}

RectI ClipmapRenderer::level_region(int32_t l) const {
  const Level& level = level_[size_t(l)];
  return {level.region_x, level.region_y, level.region_x + region_size_, level.region_y + region_size_};
}

std::vector<uint32_t> ClipmapRenderer::read_level_normals(int32_t l, const RectI& rect) const {
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  // Signed normalized 16-bit reads back as GL_SHORT exactly; packed like protocol/normal_map.h.
  std::vector<int16_t> all(size_t(tex_size_) * size_t(tex_size_) * 2);
  std::vector<uint32_t> out;
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glGetTextureImage(level_[size_t(l)].normals.get(), 0, GL_RG, GL_SHORT, GLsizei(all.size() * 2), all.data());
  for (int64_t y = rect.y0; y < rect.y1; ++y) {
    for (int64_t x = rect.x0; x < rect.x1; ++x) {
      const size_t i = size_t(floor_mod(y, tex_size_) * tex_size_ + floor_mod(x, tex_size_)) * 2;
      out.push_back(uint32_t(uint16_t(all[i])) | (uint32_t(uint16_t(all[i + 1])) << 16));
    }
  }
  return out;
}

void ClipmapRenderer::invalidate(const RectI& mip0_rect) {
  for (int32_t l = 0; l < levels_; ++l) {
    Level& level = level_[size_t(l)];
    if (!level.valid) continue;
    const RectI held = level_region(l);
    // Samples past the world's edge repeat the level's edge sample: an edit reaching it
    // changes them too (level_samples_reading).
    const RectI r = terrain::level_samples_reading(source_->params(), l, mip0_rect).intersect(held);
    if (r.empty()) continue;
    upload(level, l, r);
    update_normals(l, r);
  }
}

void ClipmapRenderer::invalidate_detail(const RectI& detail_rect) {
  if (detail_) detail_->invalidate(*source_, detail_rect);
}

size_t ClipmapRenderer::gpu_bytes() const {
  const size_t level_texels = size_t(tex_size_) * size_t(tex_size_);
  size_t bytes = size_t(levels_) * level_texels * (2 + 4);  // R16UI heights, RG16_SNORM normals
  if (detail_) bytes += detail_->gpu_bytes();
  if (mesh_) bytes += mesh_->indices().size() * sizeof(uint32_t);
  if (config_.look.materials) bytes += size_t(levels_) * level_texels * 2;  // R16F change
  bytes += look_->gpu_bytes();
  return bytes;
}

FrameStats ClipmapRenderer::render(const scene::Camera& camera, int32_t width, int32_t height) {
  FrameStats stats;
  stats.texels_uploaded = update_levels(camera);
  // Normal maps and detail gradients written by compute must be visible to the draw.
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT);
  const WorldParams& p = source_->params();
  const double mps = p.meters_per_sample;
  const auto c = lod_center_samples(camera);
  // The anchor: the outermost origin, a multiple of 2^L samples, so that moving the world by
  // such a multiple changes no float the GPU sees.
  const int64_t ax = placed_.back().origin_x, ay = placed_.back().origin_y;
  const glm::vec2 cam_offset(float(camera.x - double(ax) * mps), float(camera.y - double(ay) * mps));

  const glm::mat4 vp = scene::view_projection(camera, width, height);
  const scene::Frustum frustum = scene::frustum_of(vp);

  const int32_t n = config_.n, m = (n + 1) / 4;
  const RectI world = p.sample_rect();
  const double skirt_m = config_.min_height_m - kSkirtDepthM;
  ClipmapFrameBlock f{};
  std::copy_n(&vp[0][0], 16, f.view_proj);
  f.world_rel[0] = GLint(world.x0 - ax), f.world_rel[1] = GLint(world.y0 - ay);
  f.world_rel[2] = GLint(world.x1 - ax), f.world_rel[3] = GLint(world.y1 - ay);
  put(f.cam_offset, cam_offset);
  f.n = n;
  f.tex_size = tex_size_;
  f.half_m = 2 * m - 2;
  f.meters_per_sample = float(mps);
  f.meters_per_unit = float(p.meters_per_unit);
  f.height_base = float(p.height_offset - camera.z);
  f.band = config_.morph ? float(lod::morph_band(n)) : 0.0f;
  f.skirt_z = float(p.height_offset + skirt_m - camera.z);
  TerrainShadingBlock shading =
      look_->frame(p, ax, ay, config_.min_height_m, config_.max_height_m, config_.view_distance);
  shading.change_on = config_.look.materials && change_known_ ? 1 : 0;
  if (detail_) {
    detail_->fill(shading, p, ax, ay);
    detail_->bind();
  }
  const int64_t tn = tex_size_;
  for (int32_t l = 0; l < levels_; ++l) {
    const lod::LevelPlacement& lp = placed_[size_t(l)];
    const int64_t s = lp.spacing();
    ClipmapLevelBlock b{};
    b.tex_base[0] = GLint(floor_mod(lp.origin_x >> l, tn)),
    b.tex_base[1] = GLint(floor_mod(lp.origin_y >> l, tn));
    b.rel_origin[0] = GLint(lp.origin_x - ax), b.rel_origin[1] = GLint(lp.origin_y - ay);
    b.spacing = GLint(s);
    put(b.viewer, glm::vec2(float((c[0] - double(lp.origin_x)) / double(s)),
                            float((c[1] - double(lp.origin_y)) / double(s))));
    b.has_coarse = l + 1 < levels_ ? 1 : 0;
    if (b.has_coarse) {
      const lod::LevelPlacement& cp = placed_[size_t(l + 1)];
      b.rel_origin_coarse[0] = GLint(cp.origin_x - ax), b.rel_origin_coarse[1] = GLint(cp.origin_y - ay);
      b.tex_base_coarse[0] = GLint(floor_mod(cp.origin_x >> (l + 1), tn));
      b.tex_base_coarse[1] = GLint(floor_mod(cp.origin_y >> (l + 1), tn));
    }
    b.detail_displace = l == 0 && detail_ && config_.detail_displacement ? 1 : 0;
    level_block_->write(l, b);
  }

  // The sun's shadow map: the terrain drawn from the sun over a square around the camera.
  if (const auto sun =
          look_->shadow_frame(camera, p, config_.min_height_m, config_.max_height_m, config_.view_distance)) {
    ClipmapFrameBlock light = f;
    std::copy_n(&sun->light_view_proj[0][0], 16, light.view_proj);
    frame_block_->write(1, light);
    look_->render_shadow(*sun, shading, [&] {
      // The vertex stage reads the detail fields (displacement) from the shading block.
      look_->bind(shading);
      frame_block_->bind(kFrameBinding, 1);
      glUseProgram(shadow_program_.get());
      glBindVertexArray(vao_.get());
      FrameStats shadow_stats;
      draw_levels(camera, scene::frustum_of(sun->light_view_proj), cam_offset, shadow_stats);
      stats.shadow_triangles = shadow_stats.triangles;
      stats.draw_calls += shadow_stats.draw_calls;
    });
  }

  look_->bind(shading);
  frame_block_->write(0, f);
  frame_block_->bind(kFrameBinding, 0);
  glUseProgram(program_.get());
  glBindVertexArray(vao_.get());
  const ReversedDepthTest depth_test;
  glViewport(0, 0, width, height);
  draw_levels(camera, frustum, cam_offset, stats);
  glBindVertexArray(0);
  glUseProgram(0);
  return stats;
}

void ClipmapRenderer::draw_levels(const scene::Camera& camera, const scene::Frustum& frustum,
                                  const glm::vec2& cam_offset, FrameStats& stats) {
  const WorldParams& p = source_->params();
  const double mps = p.meters_per_sample;
  const int64_t ax = placed_.back().origin_x, ay = placed_.back().origin_y;
  const int64_t tn = tex_size_;
  const float z_margin =
      float(kSkirtDepthM + (config_.detail_displacement ? 128.0 * p.detail_meters_per_unit : 0.0));
  for (int32_t l = 0; l < levels_; ++l) {
    const lod::LevelPlacement& lp = placed_[size_t(l)];
    const Level& level = level_[size_t(l)];
    const int64_t s = lp.spacing();
    const int64_t ox = lp.origin_x >> l, oy = lp.origin_y >> l;
    level_block_->bind(kLevelBinding, l);
    glBindTextureUnit(0, level.texture.get());
    glBindTextureUnit(1, level.normals.get());
    if (l + 1 < levels_) glBindTextureUnit(2, level_[size_t(l + 1)].normals.get());
    if (level.change) glBindTextureUnit(kChangeUnit, level.change.get());
    std::vector<const lod::Piece*> pieces;
    for (const lod::Piece& piece : mesh_->ring()) pieces.push_back(&piece);
    pieces.push_back(lp.trim_variant < 0 ? &mesh_->fill() : &mesh_->trim(lp.trim_variant));
    if (l + 1 < levels_) pieces.push_back(&mesh_->degenerate());
    for (const lod::Piece* piece : pieces) {
      if (config_.cull && piece->kind != lod::PieceKind::kDegenerate) {
        // Height bounds over the piece and the neighbours its morph target reads.
        uint16_t lo = 65535, hi = 0;
        for (int32_t y = piece->y0 - 1; y <= piece->y1 + 1; ++y) {
          const int64_t row = floor_mod(oy + y, tn) * tn;
          for (int32_t x = piece->x0 - 1; x <= piece->x1 + 1; ++x) {
            const uint16_t v = level.mirror[size_t(row + floor_mod(ox + x, tn))];
            lo = std::min(lo, v), hi = std::max(hi, v);
          }
        }
        const float x0 = float(double(lp.origin_x - ax + piece->x0 * s) * mps) - cam_offset.x;
        const float x1 = float(double(lp.origin_x - ax + piece->x1 * s) * mps) - cam_offset.x;
        const float y0 = -(float(double(lp.origin_y - ay + piece->y1 * s) * mps) - cam_offset.y);
        const float y1 = -(float(double(lp.origin_y - ay + piece->y0 * s) * mps) - cam_offset.y);
        // Skirts and detail displacement reach below (and above) the level's samples.
        const float z0 = float(p.height_offset - camera.z + double(lo) * p.meters_per_unit) - z_margin;
        const float z1 = float(p.height_offset - camera.z + double(hi) * p.meters_per_unit) + z_margin;
        if (scene::box_outside(frustum, {x0, y0, z0}, {x1, y1, z1})) {
          ++stats.pieces_culled;
          continue;
        }
      }
      glDrawElements(GL_TRIANGLES, GLsizei(piece->index_count), GL_UNSIGNED_INT,
                     reinterpret_cast<const void*>(uintptr_t(piece->first_index) * sizeof(uint32_t)));
      ++stats.draw_calls;
      if (piece->kind != lod::PieceKind::kDegenerate) stats.triangles += piece->index_count / 3;
    }
  }
}

}  // namespace loam::render
