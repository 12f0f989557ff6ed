#include "client/render/clipmap_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <string>

#include "gpu/shader_library.h"

namespace loam::render {

void WorldHeightSource::read(int32_t mip, const RectI& rect, std::span<uint16_t> out) const {
  if (mip == 0) {
    world_.read_coarse(rect, out);
    return;
  }
  size_t i = 0;
  const int64_t s = int64_t(1) << mip;
  for (int64_t y = rect.y0; y < rect.y1; ++y) {
    for (int64_t x = rect.x0; x < rect.x1; ++x) out[i++] = world_.coarse(x * s, y * s);
  }
}

Result<std::unique_ptr<ClipmapRenderer>> ClipmapRenderer::create(const HeightSource& source,
                                                                 const RendererConfig& config) {
  auto mesh = ClipmapMesh::build(config.n);
  if (!mesh) return mesh.error();
  std::unique_ptr<ClipmapRenderer> r(new ClipmapRenderer());
  r->source_ = &source;
  r->config_ = config;
  const WorldParams& p = source.params();
  r->levels_ = config.levels > 0
                   ? config.levels
                   : levels_for_view_distance(config.n, p.meters_per_sample, config.view_distance);
  if (r->levels_ < 1 || r->levels_ > kMaxClipmapLevels) {
    return make_error(ErrorCode::kInvalidArgument, "clipmap.levels",
                      "must be 1.." + std::to_string(kMaxClipmapLevels));
  }
  r->tex_size_ = config.n + 2 * kLevelPad;
  r->mesh_ = std::move(*mesh);
  if (config.min_height_m >= config.max_height_m) {
    // Material range from a mip small enough to scan at once.
    const RectI world = p.sample_rect();
    int32_t mip = 0;
    while ((world.area() >> (2 * mip)) > (1 << 20)) ++mip;
    const RectI r_mip{floor_div(world.x0, int64_t(1) << mip), floor_div(world.y0, int64_t(1) << mip),
                      ceil_div(world.x1, int64_t(1) << mip), ceil_div(world.y1, int64_t(1) << mip)};
    std::vector<uint16_t> s(size_t(r_mip.area()));
    source.read(mip, r_mip, s);
    const auto [lo, hi] = std::minmax_element(s.begin(), s.end());
    r->config_.min_height_m = double(*lo) * p.meters_per_unit;
    r->config_.max_height_m = double(*hi) * p.meters_per_unit;
  }
  for (int32_t l = 0; l < r->levels_; ++l) {
    Level level;
    level.texture = gpu::make_texture(GL_TEXTURE_2D);
    glTextureStorage2D(level.texture.get(), 1, GL_R16UI, r->tex_size_, r->tex_size_);
    // An integer texture with the default mipmapped min filter is incomplete and reads 0.
    glTextureParameteri(level.texture.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(level.texture.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    level.mirror.assign(size_t(r->tex_size_) * size_t(r->tex_size_), 0);
    r->level_.push_back(std::move(level));
  }
  r->indices_ = gpu::make_buffer();
  const auto& idx = r->mesh_->indices();
  glNamedBufferStorage(r->indices_.get(), GLsizeiptr(idx.size() * sizeof(uint32_t)), idx.data(), 0);
  GLuint vao = 0;
  glCreateVertexArrays(1, &vao);
  r->vao_ = gpu::GlVertexArray(vao);
  glVertexArrayElementBuffer(vao, r->indices_.get());
  auto program = gpu::build_graphics_program("clipmap.vert.glsl", "clipmap.frag.glsl");
  if (!program) return program.error();
  r->program_ = std::move(*program);
  return r;
}

std::array<double, 2> ClipmapRenderer::lod_center_samples(const Camera& camera) const {
  const double mps = source_->params().meters_per_sample;
  const auto c = camera.lod_center.value_or(std::array<double, 2>{camera.x, camera.y});
  return {c[0] / mps, c[1] / mps};
}

int64_t ClipmapRenderer::upload(Level& level, int32_t mip, const RectI& rect) {
  const int64_t n = tex_size_;
  int64_t texels = 0;
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  // A rect no wider than the texture wraps at most once per axis: up to four pieces.
  for (int64_t y = rect.y0; y < rect.y1;) {
    const int64_t ty = floor_mod(y, n), h = std::min(rect.y1 - y, n - ty);
    for (int64_t x = rect.x0; x < rect.x1;) {
      const int64_t tx = floor_mod(x, n), w = std::min(rect.x1 - x, n - tx);
      scratch_.resize(size_t(w * h));
      source_->read(mip, {x, y, x + w, y + h}, scratch_);
      glTextureSubImage2D(level.texture.get(), 0, GLint(tx), GLint(ty), GLsizei(w), GLsizei(h),
                          GL_RED_INTEGER, GL_UNSIGNED_SHORT, scratch_.data());
      for (int64_t j = 0; j < h; ++j) {
        std::copy_n(scratch_.begin() + j * w, w, level.mirror.begin() + (ty + j) * n + tx);
      }
      texels += w * h;
      x += w;
    }
    y += h;
  }
  return texels;
}

int64_t ClipmapRenderer::update_levels(const Camera& camera) {
  const auto c = lod_center_samples(camera);
  placed_ = place_levels(config_.n, levels_, c[0], c[1]);
  const int64_t n = tex_size_;
  int64_t texels = 0;
  for (int32_t l = 0; l < levels_; ++l) {
    Level& level = level_[size_t(l)];
    const int64_t rx = (placed_[size_t(l)].origin_x >> l) - kLevelPad;
    const int64_t ry = (placed_[size_t(l)].origin_y >> l) - kLevelPad;
    const RectI now{rx, ry, rx + n, ry + n};
    if (!level.valid || std::abs(rx - level.region_x) >= n || std::abs(ry - level.region_y) >= n) {
      texels += upload(level, l, now);
    } else {
      // Only what came into view: the columns entering at one side over the full new height,
      // then the rows entering over the columns both regions share.
      const RectI old{level.region_x, level.region_y, level.region_x + n, level.region_y + n};
      if (rx > old.x0) texels += upload(level, l, {old.x1, ry, now.x1, now.y1});
      if (rx < old.x0) texels += upload(level, l, {rx, ry, old.x0, now.y1});
      const int64_t sx0 = std::max(rx, old.x0), sx1 = std::min(now.x1, old.x1);
      if (ry > old.y0) texels += upload(level, l, {sx0, old.y1, sx1, now.y1});
      if (ry < old.y0) texels += upload(level, l, {sx0, ry, sx1, old.y0});
    }
    level.valid = true;
    level.region_x = rx;
    level.region_y = ry;
  }
  return texels;
}

void ClipmapRenderer::invalidate(const RectI& mip0_rect) {
  for (int32_t l = 0; l < levels_; ++l) {
    Level& level = level_[size_t(l)];
    if (!level.valid) continue;
    const int64_t s = int64_t(1) << l;
    // Level sample i is mip-0 sample i * s: those inside the rect.
    const RectI mine{ceil_div(mip0_rect.x0, s), ceil_div(mip0_rect.y0, s), ceil_div(mip0_rect.x1, s),
                     ceil_div(mip0_rect.y1, s)};
    const RectI held{level.region_x, level.region_y, level.region_x + tex_size_, level.region_y + tex_size_};
    const RectI r = mine.intersect(held);
    if (!r.empty()) upload(level, l, r);
  }
}

namespace {

GLint loc(GLuint program, const char* name) { return glGetUniformLocation(program, name); }

}  // namespace

FrameStats ClipmapRenderer::render(const Camera& camera, int32_t width, int32_t height) {
  FrameStats stats;
  stats.texels_uploaded = update_levels(camera);
  const WorldParams& p = source_->params();
  const double mps = p.meters_per_sample;
  const auto c = lod_center_samples(camera);
  // The anchor: the outermost origin, a multiple of 2^L samples, so that moving the world by
  // such a multiple changes no float the GPU sees.
  const int64_t ax = placed_.back().origin_x, ay = placed_.back().origin_y;
  const glm::vec2 cam_offset(float(camera.x - double(ax) * mps), float(camera.y - double(ay) * mps));

  const glm::vec3 fwd(float(camera.fx), float(-camera.fy), float(camera.fz));
  const glm::vec3 up(float(camera.ux), float(-camera.uy), float(camera.uz));
  const glm::mat4 view = glm::lookAt(glm::vec3(0.0f), fwd, up);
  const float aspect = float(width) / float(std::max(height, 1));
  glm::mat4 proj;
  if (camera.ortho_half_height > 0) {
    const float hh = float(camera.ortho_half_height);
    proj = glm::ortho(-hh * aspect, hh * aspect, -hh, hh, float(camera.near_m), float(camera.far_m));
  } else {
    proj = glm::perspective(glm::radians(float(camera.fov_y_degrees)), aspect, float(camera.near_m),
                            float(camera.far_m));
  }
  const glm::mat4 vp = proj * view;
  // Frustum planes (Gribb & Hartmann): rows of the view-projection matrix combined.
  std::array<glm::vec4, 6> planes;
  const glm::mat4 t = glm::transpose(vp);
  for (int i = 0; i < 3; ++i) {
    planes[size_t(2 * i)] = t[3] + t[i];
    planes[size_t(2 * i + 1)] = t[3] - t[i];
  }

  const GLuint prog = program_.get();
  glUseProgram(prog);
  glBindVertexArray(vao_.get());
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glViewport(0, 0, width, height);
  const int32_t n = config_.n, m = (n + 1) / 4;
  glUniform1i(loc(prog, "u_n"), n);
  glUniform1i(loc(prog, "u_tex_size"), tex_size_);
  glUniform2fv(loc(prog, "u_cam_offset"), 1, glm::value_ptr(cam_offset));
  glUniform1f(loc(prog, "u_meters_per_sample"), float(mps));
  glUniform1f(loc(prog, "u_meters_per_unit"), float(p.meters_per_unit));
  glUniform1f(loc(prog, "u_height_base"), float(p.height_offset - camera.z));
  glUniform1f(loc(prog, "u_band"), config_.morph ? float(morph_band(n)) : 0.0f);
  glUniform1i(loc(prog, "u_half_m"), 2 * m - 2);
  glUniformMatrix4fv(loc(prog, "u_view_proj"), 1, GL_FALSE, glm::value_ptr(vp));
  const float az = glm::radians(config_.sun_azimuth_degrees),
              el = glm::radians(config_.sun_elevation_degrees);
  // Azimuth clockwise from north, in the render frame (x east, y north).
  const glm::vec3 sun(std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el));
  glUniform3fv(loc(prog, "u_sun_dir"), 1, glm::value_ptr(sun));
  glUniform2f(loc(prog, "u_height_range"), float(config_.min_height_m), float(config_.max_height_m));
  glUniform1f(loc(prog, "u_sea_level"), float(-p.height_offset));
  const glm::vec3 fog(0.50f, 0.60f, 0.75f);
  glUniform3fv(loc(prog, "u_fog_color"), 1, glm::value_ptr(fog));
  glUniform1f(loc(prog, "u_fog_density"), float(1.0 / (config_.view_distance * 1.5)));
  glUniform1i(loc(prog, "u_debug_morph"), 0);

  const int64_t tn = tex_size_;
  for (int32_t l = 0; l < levels_; ++l) {
    const LevelPlacement& lp = placed_[size_t(l)];
    const Level& level = level_[size_t(l)];
    const int64_t s = lp.spacing();
    glBindTextureUnit(0, level.texture.get());
    const int64_t ox = lp.origin_x >> l, oy = lp.origin_y >> l;
    glUniform2i(loc(prog, "u_tex_base"), GLint(floor_mod(ox, tn)), GLint(floor_mod(oy, tn)));
    glUniform2i(loc(prog, "u_rel_origin"), GLint(lp.origin_x - ax), GLint(lp.origin_y - ay));
    glUniform1i(loc(prog, "u_spacing"), GLint(s));
    glUniform2f(loc(prog, "u_viewer"), float((c[0] - double(lp.origin_x)) / double(s)),
                float((c[1] - double(lp.origin_y)) / double(s)));
    std::vector<const Piece*> pieces;
    for (const Piece& piece : mesh_->ring()) pieces.push_back(&piece);
    pieces.push_back(lp.trim_variant < 0 ? &mesh_->fill() : &mesh_->trim(lp.trim_variant));
    if (l + 1 < levels_) pieces.push_back(&mesh_->degenerate());
    for (const Piece* piece : pieces) {
      if (config_.cull && piece->kind != PieceKind::kDegenerate) {
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
        const float z0 = float(p.height_offset - camera.z + double(lo) * p.meters_per_unit);
        const float z1 = float(p.height_offset - camera.z + double(hi) * p.meters_per_unit);
        bool outside = false;
        for (const glm::vec4& pl : planes) {
          const glm::vec3 pv(pl.x >= 0 ? x1 : x0, pl.y >= 0 ? y1 : y0, pl.z >= 0 ? z1 : z0);
          if (glm::dot(glm::vec3(pl), pv) + pl.w < 0) {
            outside = true;
            break;
          }
        }
        if (outside) {
          ++stats.pieces_culled;
          continue;
        }
      }
      glDrawElements(GL_TRIANGLES, GLsizei(piece->index_count), GL_UNSIGNED_INT,
                     reinterpret_cast<const void*>(uintptr_t(piece->first_index) * sizeof(uint32_t)));
      ++stats.draw_calls;
      if (piece->kind != PieceKind::kDegenerate) stats.triangles += piece->index_count / 3;
    }
  }
  glBindVertexArray(0);
  glUseProgram(0);
  return stats;
}

}  // namespace loam::render
