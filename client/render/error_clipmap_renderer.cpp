#include "client/render/error_clipmap_renderer.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>

#include "client/lod/clipmap_mesh.h"
#include "client/lod/projected_error.h"
#include "client/render/reversed_depth.h"
#include "client/render/toroidal_upload.h"
#include "client/scene/frustum.h"

namespace loam::render {

namespace {

constexpr GLuint kErrorClipmapFrameBinding = 4;  // shaders/error_clipmap_frame.glsl

// A filtered 2D array of `layers` tori of size^2 texels: GL_REPEAT joins each torus's seams.
gpu::GlTexture filtered_torus_array(GLenum format, int32_t size, int32_t layers) {
  gpu::GlTexture t = gpu::make_texture(GL_TEXTURE_2D_ARRAY);
  glTextureStorage3D(t.get(), 1, format, size, size, layers);
  glTextureParameteri(t.get(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(t.get(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(t.get(), GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTextureParameteri(t.get(), GL_TEXTURE_WRAP_T, GL_REPEAT);
  return t;
}

// A 2D texture viewing one layer of a 2D array texture (its storage shared).
gpu::GlTexture layer_view(GLuint array, GLenum format, int32_t layer) {
  GLuint v = 0;
  glGenTextures(1, &v);  // a view needs a name never bound, which glCreateTextures would give
  glTextureView(v, GL_TEXTURE_2D, array, format, 0, 1, GLuint(layer), 1);
  return gpu::GlTexture(v);
}

}  // namespace

Result<std::unique_ptr<ErrorClipmapRenderer>> ErrorClipmapRenderer::create(
    const terrain::HeightSource& source, const ErrorClipmapConfig& config) {
  const WorldParams& p = source.params();
  std::unique_ptr<ErrorClipmapRenderer> r(new ErrorClipmapRenderer());
  r->source_ = &source;
  r->config_ = config;
  r->world_ = p.sample_rect();
  r->scale_ = {p.meters_per_sample, p.meters_per_unit, p.height_offset};
  const int32_t cells = config.block_size - 1;
  // Regions nest with room for the restriction's splits: a level's region reaches 8 cells of
  // its level past the finer region on every side.
  if (config.region < 16 * std::max(cells, 1) || config.region > 8192) {
    return make_error(ErrorCode::kInvalidArgument, "error_clipmap.region",
                      "must be 16 block cells to 8192 samples");
  }
  int32_t levels = config.levels;
  if (levels <= 0) {
    // Until one coarsest block spans the world (the budget then has a block for every distance)
    // and the coarsest region covers it from anywhere within a world's width: the coarse levels
    // cost a region each, and hold little of the world.
    const int64_t extent = std::max(r->world_.width(), r->world_.height());
    levels = 1;
    while (levels < lod::kMaxClipmapLevels && ((int64_t(cells) << (levels - 1)) < extent ||
                                               (int64_t(config.region) << (levels - 1)) < 4 * extent))
      ++levels;
  }
  auto grid = lod::ClipmapBlockGrid::make(r->world_.width(), r->world_.height(), config.block_size, levels);
  if (!grid) return grid.error();
  r->grid_ = *grid;
  // No larger than level 0's blocks need: a world that fits is held whole at every level.
  r->region_ = int32_t(std::min<int64_t>(
      config.region, std::max<int64_t>(16 * cells, std::max(r->level_extent(0)[0], r->level_extent(0)[1]))));
  r->patch_ = r->grid_.patch_grid();
  // Block errors for the level regions only, computed as they move (select()).
  r->errors_ = lod::ClipmapErrorPyramid::windowed(r->grid_, config.exact_levels);
  const auto [lo, hi] = terrain::coarsest_height_range_m(source);
  r->min_height_m_ = lo;
  r->max_height_m_ = hi;
  r->level_.resize(size_t(levels));
  r->regions_.resize(size_t(levels));
  r->drawable_.resize(size_t(levels));
  // A level whose blocks need no more than a layer holds them whole, beside the other such
  // levels in a shared layer (shelves left to right); the rest get a torus each. On the refined
  // 131 km world at regions of 1024, levels 8..14 share one layer: 9 layers for 15 levels.
  {
    int64_t shelf_x = 0;
    int32_t shelf = -1;
    for (int32_t l = 0; l < levels; ++l) {
      Level& level = r->level_[size_t(l)];
      const std::array<int64_t, 2> e = r->hierarchy_extent(l);
      if (e[0] > r->region_ || e[1] > r->region_) {
        level.layer = r->layers_++;
        continue;
      }
      if (shelf < 0 || shelf_x + e[0] > r->region_) shelf = r->layers_++, shelf_x = 0;
      level.layer = shelf;
      level.offset_x = shelf_x;
      shelf_x += e[0];
    }
  }
  const int32_t layers = r->layers_;

  r->levels_texture_ = gpu::make_texture(GL_TEXTURE_2D_ARRAY);
  glTextureStorage3D(r->levels_texture_.get(), 1, GL_R16UI, r->region_, r->region_, layers);
  glTextureParameteri(r->levels_texture_.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(r->levels_texture_.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  // FD4 normals per level, toroidal like the heights, filtered.
  r->normals_texture_ = filtered_torus_array(GL_RG16_SNORM, r->region_, layers);
  const GLuint normals = r->normals_texture_.get();
  // The shared normal pass reads and writes 2D textures: one view of each layer.
  for (int32_t k = 0; k < layers; ++k) {
    LayerViews v;
    v.heights = layer_view(r->levels_texture_.get(), GL_R16UI, k);
    glTextureParameteri(v.heights.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(v.heights.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    v.normals = layer_view(normals, GL_RG16_SNORM, k);
    r->layer_views_.push_back(std::move(v));
  }
  if (glGetError() != GL_NO_ERROR)
    return make_error(ErrorCode::kUnsupported, "error_clipmap.normals",
                      "texture views of the level layers failed");
  if (config.look.materials) {
    // The change layer the materials show dug earth by, toroidal like the heights, filtered.
    r->change_texture_ = filtered_torus_array(GL_R16F, r->region_, layers);
    const float zero = 0.0f;
    glClearTexImage(r->change_texture_.get(), 0, GL_RED, GL_FLOAT, &zero);
  }
  auto detail = DetailRegion::create_unless_zero(config.detail_size);
  if (!detail) return detail.error();
  r->detail_ = std::move(*detail);
  if (!(config.view_distance > 0)) {
    return make_error(ErrorCode::kInvalidArgument, "error_clipmap.view_distance", "must be positive");
  }
  auto look = TerrainLook::create(config.look);
  if (!look) return look.error();
  r->look_.emplace(std::move(*look));
  auto normal_pass = gpu::LevelNormalPass::create();
  if (!normal_pass) return normal_pass.error();
  r->normal_pass_.emplace(std::move(*normal_pass));
  auto fill = gpu::LevelFill::create(r->grid_.levels);
  if (!fill) return fill.error();
  r->fill_.emplace(std::move(*fill));

  const std::string_view vertex[] = {"geomipmap_blocks.glsl", "error_clipmap_frame.glsl", "patch_morph.glsl",
                                     "error_clipmap.vert.glsl"};
  const std::string_view fragment[] = {"terrain_shading_block.glsl", "terrain_shading.glsl",
                                       "error_clipmap.frag.glsl"};
  auto own_block = [](GLuint program) {
    return gpu::verify_uniform_block(program, "ErrorClipmapFrame", sizeof(ErrorClipmapFrameBlock),
                                     kErrorClipmapFrameMembers);
  };
  auto program = build_patch_program(vertex, fragment, [&](GLuint linked) -> Status {
    LOAM_TRY(own_block(linked));
    return TerrainLook::verify(linked);
  });
  if (!program) return program.error();
  r->program_ = std::move(*program);
  if (config.look.shadows) {
    const std::string_view depth[] = {"shadow_depth.frag.glsl"};
    auto shadow = build_patch_program(vertex, depth, own_block);
    if (!shadow) return shadow.error();
    r->shadow_program_ = std::move(*shadow);
  }
  r->frame_block_.emplace(2);
  r->error_block_.emplace(1);
  r->vao_ = make_patch_vertex_array();
  r->indices_.emplace(r->vao_.get());
  r->instances_.emplace(r->vao_.get());
  return r;
}

void ErrorClipmapRenderer::read_level(int32_t l, const RectI& rect, std::span<uint16_t> out) const {
  if (rect.empty()) return;
  const int64_t s = int64_t(1) << l, w = rect.width();
  const int64_t W = world_.width(), H = world_.height();
  // Level samples at mip-0 positions up to the world's last sample come from the mip (or from
  // mip 0 at a stride where the world's origin is not on the mip's grid).
  const RectI inside = rect.intersect({INT64_MIN / 4, INT64_MIN / 4, (W - 1) / s + 1, (H - 1) / s + 1});
  if (!inside.empty()) {
    std::vector<uint16_t> part(size_t(inside.area()));
    if (floor_mod(world_.x0, s) == 0 && floor_mod(world_.y0, s) == 0) {
      source_->read(l,
                    {inside.x0 + world_.x0 / s, inside.y0 + world_.y0 / s, inside.x1 + world_.x0 / s,
                     inside.y1 + world_.y0 / s},
                    part);
    } else {
      std::vector<uint16_t> one(1);
      size_t i = 0;
      for (int64_t y = inside.y0; y < inside.y1; ++y) {
        for (int64_t x = inside.x0; x < inside.x1; ++x) {
          const int64_t gx = world_.x0 + std::clamp<int64_t>(x * s, 0, W - 1);
          const int64_t gy = world_.y0 + std::clamp<int64_t>(y * s, 0, H - 1);
          source_->read(0, {gx, gy, gx + 1, gy + 1}, one);
          part[i++] = one[0];
        }
      }
    }
    for (int64_t y = inside.y0; y < inside.y1; ++y)
      std::copy_n(part.begin() + (y - inside.y0) * inside.width(), inside.width(),
                  out.begin() + (y - rect.y0) * w + (inside.x0 - rect.x0));
  }
  if (inside == rect) return;
  // Beyond the far edges: mip 0's edge samples, one read per row or column of the rect.
  std::vector<uint16_t> one(1);
  auto edge = [&](int64_t x, int64_t y) {
    const int64_t gx = world_.x0 + std::clamp<int64_t>(x * s, 0, W - 1);
    const int64_t gy = world_.y0 + std::clamp<int64_t>(y * s, 0, H - 1);
    source_->read(0, {gx, gy, gx + 1, gy + 1}, one);
    return one[0];
  };
  // Columns beyond, in rows that are not: the row's edge sample.
  for (int64_t y = rect.y0; y < rect.y1 && y * s <= H - 1; ++y) {
    const int64_t first = std::max(rect.x0, (W - 1) / s + 1);
    if (first >= rect.x1) break;
    std::fill_n(out.begin() + (y - rect.y0) * w + (first - rect.x0), rect.x1 - first, edge(first, y));
  }
  // Rows beyond: every such row equals the first row beyond, computed once.
  const int64_t first_beyond = std::max(rect.y0, (H - 1) / s + 1);
  if (first_beyond < rect.y1) {
    std::vector<uint16_t> row(static_cast<size_t>(w));
    for (int64_t x = rect.x0; x < rect.x1; ++x) row[size_t(x - rect.x0)] = edge(x, first_beyond);
    for (int64_t y = first_beyond; y < rect.y1; ++y)
      std::copy(row.begin(), row.end(), out.begin() + (y - rect.y0) * w);
  }
}

RectI ErrorClipmapRenderer::region(int32_t l) const { return regions_[size_t(l)]; }

RectI ErrorClipmapRenderer::to_global(int32_t l, const RectI& local) const {
  // Clipped to the world's level samples: a coarse level's region reaches far past a small world.
  const int64_t s = int64_t(1) << l;
  const RectI r = local.intersect({0, 0, ceil_div(world_.width(), s), ceil_div(world_.height(), s)});
  const int64_t ox = floor_div(world_.x0, s), oy = floor_div(world_.y0, s);
  return r.empty() ? RectI{} : RectI{r.x0 + ox, r.y0 + oy, r.x1 + ox, r.y1 + oy};
}

RectI ErrorClipmapRenderer::level_region(int32_t l) const { return to_global(l, regions_[size_t(l)]); }

std::vector<RectI> ErrorClipmapRenderer::level_regions_for(const scene::Camera& lod_camera) const {
  std::vector<RectI> out = regions_for(lod_camera);
  for (size_t l = 0; l < out.size(); ++l) out[l] = to_global(int32_t(l), out[l]);
  return out;
}

std::vector<RectI> ErrorClipmapRenderer::regions_for(const scene::Camera& lod_camera) const {
  const double mps = scale_.meters_per_sample;
  const int64_t n = region_;
  // The LOD centre, world-relative meters.
  const auto c = lod_camera.lod_center.value_or(std::array<double, 2>{lod_camera.x, lod_camera.y});
  const double ex = c[0] - double(world_.x0) * mps, ey = c[1] - double(world_.y0) * mps;
  std::vector<RectI> out;
  for (int32_t l = 0; l < grid_.levels; ++l) {
    const double s = double(int64_t(1) << l) * mps;
    // Centred on the camera, but inside what the level's blocks need: nothing is held outside
    // the world, and a level whose blocks fit is held whole.
    const std::array<int64_t, 2> e = level_extent(l), h = hierarchy_extent(l);
    auto place = [&](double eye, int64_t extent) {
      return std::clamp<int64_t>(int64_t(std::floor(eye / s)) - n / 2, 0, std::max<int64_t>(0, extent - n));
    };
    if (h[0] <= n && h[1] <= n) {
      out.push_back({0, 0, h[0], h[1]});  // whole (and maybe sharing a layer): what the hierarchy reads
      continue;
    }
    const int64_t rx = place(ex, e[0]), ry = place(ey, e[1]);
    out.push_back({rx, ry, rx + n, ry + n});
  }
  return out;
}

std::array<int64_t, 2> ErrorClipmapRenderer::hierarchy_extent(int32_t l) const {
  const int32_t top = grid_.levels - 1;
  return {(int64_t(grid_.blocks_x(top)) << (top - l)) * grid_.cells() + 1,
          (int64_t(grid_.blocks_y(top)) << (top - l)) * grid_.cells() + 1};
}

std::array<int64_t, 2> ErrorClipmapRenderer::level_extent(int32_t l) const {
  return {int64_t(grid_.blocks_x(l)) * grid_.cells() + 1, int64_t(grid_.blocks_y(l)) * grid_.cells() + 1};
}

int64_t ErrorClipmapRenderer::upload(int32_t l, const RectI& rect) {
  const int64_t n = region_, s = int64_t(1) << l;
  scratch_.resize(size_t(rect.area()));
  read_level(l, rect, scratch_);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, GLint(rect.width()));
  const RectI t = shifted(l, rect);
  const GLint layer = level_[size_t(l)].layer;
  const int64_t texels = for_each_torus_piece(t, n, [&](const RectI& piece, int64_t tx, int64_t ty) {
    const uint16_t* data = scratch_.data() + (piece.y0 - t.y0) * rect.width() + (piece.x0 - t.x0);
    glTextureSubImage3D(levels_texture_.get(), 0, GLint(tx), GLint(ty), layer, GLsizei(piece.width()),
                        GLsizei(piece.height()), 1, GL_RED_INTEGER, GL_UNSIGNED_SHORT, data);
  });
  if (change_texture_) {
    // Where the level reads its mip (the world's origin on the mip's grid), the mip's change;
    // elsewhere (past the far edges, or off the grid) none.
    change_scratch_.assign(size_t(rect.area()), 0.0f);
    const int64_t W = world_.width(), H = world_.height();
    const RectI inside = rect.intersect({0, 0, (W - 1) / s + 1, (H - 1) / s + 1});
    if (!inside.empty() && floor_mod(world_.x0, s) == 0 && floor_mod(world_.y0, s) == 0) {
      std::vector<float>& part = change_part_;
      part.resize(size_t(inside.area()));
      const RectI global{inside.x0 + world_.x0 / s, inside.y0 + world_.y0 / s, inside.x1 + world_.x0 / s,
                         inside.y1 + world_.y0 / s};
      if (source_->read_change(l, global, part)) {
        change_known_ = true;
        for (int64_t y = inside.y0; y < inside.y1; ++y)
          std::copy_n(part.begin() + (y - inside.y0) * inside.width(), inside.width(),
                      change_scratch_.begin() + (y - rect.y0) * rect.width() + (inside.x0 - rect.x0));
      }
    }
    for_each_torus_piece(t, n, [&](const RectI& piece, int64_t tx, int64_t ty) {
      const float* data = change_scratch_.data() + (piece.y0 - t.y0) * rect.width() + (piece.x0 - t.x0);
      glTextureSubImage3D(change_texture_.get(), 0, GLint(tx), GLint(ty), layer, GLsizei(piece.width()),
                          GLsizei(piece.height()), 1, GL_RED, GL_FLOAT, data);
    });
  }
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  return texels;
}

RectI ErrorClipmapRenderer::shifted(int32_t l, const RectI& r) const {
  const Level& level = level_[size_t(l)];
  return {r.x0 + level.offset_x, r.y0 + level.offset_y, r.x1 + level.offset_x, r.y1 + level.offset_y};
}

RectI ErrorClipmapRenderer::drawable(int32_t l) const {
  // Normals' stencils reach 2 samples (4, one-sided, at the world's edges): where the world
  // goes on past the region, its last 4 samples hold heights but no normals.
  const RectI& r = regions_[size_t(l)];
  const int64_t s = int64_t(1) << l;
  const int64_t wx = (world_.width() - 1) / s + 1, wy = (world_.height() - 1) / s + 1;
  return {r.x0 > 0 ? r.x0 + 4 : r.x0, r.y0 > 0 ? r.y0 + 4 : r.y0, r.x1 < wx ? r.x1 - 4 : r.x1,
          r.y1 < wy ? r.y1 - 4 : r.y1};
}

void ErrorClipmapRenderer::update_normals(int32_t l, const RectI& changed) {
  // Heights changed in `changed`: normals up to 4 samples around it, where they are defined.
  const RectI r =
      RectI{changed.x0 - 4, changed.y0 - 4, changed.x1 + 4, changed.y1 + 4}.intersect(drawable_[size_t(l)]);
  if (r.empty()) return;
  const int64_t s = int64_t(1) << l;
  const RectI world{0, 0, (world_.width() - 1) / s + 1, (world_.height() - 1) / s + 1};
  // In texel coordinates: a level sharing a layer computes where it lies in it.
  const LayerViews& v = layer_views_[size_t(level_[size_t(l)].layer)];
  normal_pass_->update(v.heights.get(), v.normals.get(), region_, shifted(l, regions_[size_t(l)]),
                       shifted(l, r), shifted(l, world), source_->params(),
                       scale_.meters_per_sample * double(s));
}

template <class T>
std::vector<T> ErrorClipmapRenderer::read_level_texels(GLuint texture, GLenum format, GLenum type, int32_t l,
                                                       const RectI& rect) const {
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  const int64_t n = region_;
  std::vector<T> layer(size_t(n * n));
  glPixelStorei(GL_PACK_ALIGNMENT, GLint(sizeof(T)));
  const Level& level = level_[size_t(l)];
  glGetTextureSubImage(texture, 0, 0, 0, level.layer, GLsizei(n), GLsizei(n), 1, format, type,
                       GLsizei(layer.size() * sizeof(T)), layer.data());
  std::vector<T> out;
  out.reserve(size_t(rect.area()));
  for (int64_t y = rect.y0; y < rect.y1; ++y) {
    for (int64_t x = rect.x0; x < rect.x1; ++x)
      out.push_back(layer[size_t(floor_mod(y + level.offset_y, n) * n + floor_mod(x + level.offset_x, n))]);
  }
  return out;
}

std::vector<uint16_t> ErrorClipmapRenderer::read_level_heights(int32_t l, const RectI& rect) const {
  return read_level_texels<uint16_t>(levels_texture_.get(), GL_RED_INTEGER, GL_UNSIGNED_SHORT, l, rect);
}

std::vector<float> ErrorClipmapRenderer::read_level_change(int32_t l, const RectI& rect) const {
  if (!change_texture_) return {};
  return read_level_texels<float>(change_texture_.get(), GL_RED, GL_FLOAT, l, rect);
}

size_t ErrorClipmapRenderer::set_fill_level(int32_t l) {
  const Level& level = level_[size_t(l)];
  const int64_t s = int64_t(1) << l;
  gpu::LevelSlotBlock b{};
  // A level not placed yet holds nothing: an empty region.
  const RectI region = level.valid ? regions_[size_t(l)] : RectI{};
  const RectI draw = level.valid ? drawable_[size_t(l)] : RectI{};
  b.region[0] = int32_t(region.x0), b.region[1] = int32_t(region.y0), b.region[2] = int32_t(region.x1),
  b.region[3] = int32_t(region.y1);
  b.drawable[0] = int32_t(draw.x0), b.drawable[1] = int32_t(draw.y0), b.drawable[2] = int32_t(draw.x1),
  b.drawable[3] = int32_t(draw.y1);
  b.texel[0] = int32_t(level.offset_x), b.texel[1] = int32_t(level.offset_y), b.texel[2] = level.layer,
  b.texel[3] = region_;
  // The change layer holds the mip's change only where the level reads its mip (upload()).
  const bool aligned = floor_mod(world_.x0, s) == 0 && floor_mod(world_.y0, s) == 0;
  b.change[0] = change_texture_ && change_known_ && aligned ? 1 : 0;
  b.change[1] = int32_t((world_.width() - 1) / s + 1), b.change[2] = int32_t((world_.height() - 1) / s + 1);
  b.change[3] = int32_t(s);
  b.scale[0] = float(source_->params().meters_per_unit);
  const RectI world{0, 0, (world_.width() - 1) / s + 1, (world_.height() - 1) / s + 1};
  const gpu::NormalBlock n = gpu::level_normal_block(region_, shifted(l, region), {}, shifted(l, world),
                                                     source_->params(), scale_.meters_per_sample * double(s));
  return fill_->set_level(l, b, n);
}

std::vector<uint32_t> ErrorClipmapRenderer::read_level_normals(int32_t l, const RectI& rect) const {
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  // Signed normalized 16-bit reads back as GL_SHORT exactly; packed like protocol/normal_map.h.
  const int64_t n = region_;
  std::vector<int16_t> layer(size_t(n * n * 2));
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  const Level& level = level_[size_t(l)];
  glGetTextureSubImage(normals_texture_.get(), 0, 0, 0, level.layer, GLsizei(n), GLsizei(n), 1, GL_RG,
                       GL_SHORT, GLsizei(layer.size() * sizeof(int16_t)), layer.data());
  std::vector<uint32_t> out;
  out.reserve(size_t(rect.area()));
  for (int64_t y = rect.y0; y < rect.y1; ++y) {
    for (int64_t x = rect.x0; x < rect.x1; ++x) {
      const size_t i = size_t(floor_mod(y + level.offset_y, n) * n + floor_mod(x + level.offset_x, n)) * 2;
      out.push_back(uint32_t(uint16_t(layer[i])) | (uint32_t(uint16_t(layer[i + 1])) << 16));
    }
  }
  return out;
}

lod::LodView ErrorClipmapRenderer::lod_view(const scene::Camera& camera, int32_t viewport_width,
                                            int32_t viewport_height) const {
  const double mps = scale_.meters_per_sample;
  lod::LodView view;
  view.x = camera.x - double(world_.x0) * mps;
  view.y = camera.y - double(world_.y0) * mps;
  view.z = camera.z;
  view.pixels_per_radian = lod::pixels_per_radian(viewport_height, camera.fov_y_degrees);
  view.tolerance_px = config_.tolerance_px;
  if (camera.ortho_half_height <= 0) {
    lod::set_view_axes(view, {camera.fx, camera.fy, camera.fz}, {camera.ux, camera.uy, camera.uz},
                       camera.fov_y_degrees, double(viewport_width) / double(std::max(viewport_height, 1)));
  }
  return view;
}

ErrorClipmapFrameStats ErrorClipmapRenderer::render(const scene::Camera& camera, int32_t width,
                                                    int32_t height) {
  ErrorClipmapFrameStats s = select(camera, height, width);
  const ErrorClipmapFrameStats d = draw(camera, width, height);
  s.triangles = d.triangles, s.draw_calls = d.draw_calls, s.blocks = d.blocks,
  s.blocks_culled = d.blocks_culled;
  s.cpu_ms += d.cpu_ms;
  return s;
}

ErrorClipmapFrameStats ErrorClipmapRenderer::select(const scene::Camera& lod_camera, int32_t viewport_height,
                                                    int32_t viewport_width) {
  ErrorClipmapFrameStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  const int32_t width = viewport_width > 0 ? viewport_width : 2 * viewport_height;
  const lod::LodView view = lod_view(lod_camera, width, viewport_height);
  const double mps = scale_.meters_per_sample;
  const int64_t n = region_;
  const std::vector<RectI> placed = regions_for(lod_camera);
  for (int32_t l = 0; l < grid_.levels; ++l) {
    const int64_t rx = placed[size_t(l)].x0, ry = placed[size_t(l)].y0;
    Level& level = level_[size_t(l)];
    std::optional<std::array<int64_t, 2>> old;
    if (level.valid) old = std::array<int64_t, 2>{level.region_x, level.region_y};
    // The first placement fills the region (a whole level: exactly its blocks' samples); then
    // a torus takes the strips that came in.
    const std::vector<RectI> strips =
        old ? lod::toroidal_strips(old, {rx, ry}, n) : std::vector<RectI>{placed[size_t(l)]};
    for (const RectI& strip : strips) stats.texels_uploaded += upload(l, strip);
    level.valid = true;
    level.region_x = rx, level.region_y = ry;
    regions_[size_t(l)] = placed[size_t(l)];
    drawable_[size_t(l)] = drawable(l);
    for (const RectI& strip : strips) update_normals(l, strip);
  }
  if (detail_) {
    const auto c = lod_camera.lod_center.value_or(std::array<double, 2>{lod_camera.x, lod_camera.y});
    stats.texels_uploaded += detail_->update(*source_, c[0] / mps, c[1] / mps);
  }
  // The error pyramid follows the regions: blocks that entered one (or whose finer window
  // changed under them) are computed, the rest kept.
  std::vector<RectI> windows;
  for (int32_t l = 0; l < grid_.levels; ++l)
    windows.push_back(lod::blocks_inside(grid_, l, drawable_[size_t(l)]));
  stats.blocks_computed = errors_.move_windows(
      grid_, [&](int32_t l, const RectI& rect, std::span<uint16_t> out) { read_level(l, rect, out); },
      windows);
  // Blocks outside the view are drawn by nobody: they are not split (the draw culls them).
  const scene::Frustum frustum =
      scene::frustum_of(scene::view_projection(lod_camera, width, viewport_height));
  const int64_t c = grid_.cells();
  auto visible = [&](int32_t l, int64_t bx, int64_t by) {
    const double e = double(c << l) * mps;
    const double rel_x = double(world_.x0 + bx * (c << l)) * mps - lod_camera.x;
    const double rel_y = -(double(world_.y0 + by * (c << l)) * mps - lod_camera.y);
    const glm::vec3 lo(float(rel_x), float(rel_y - e),
                       float(scale_.meters(errors_.min_height(l, bx, by)) - lod_camera.z));
    const glm::vec3 hi(float(rel_x + e), float(rel_y),
                       float(scale_.meters(errors_.max_height(l, bx, by)) - lod_camera.z));
    return !scene::box_outside(frustum, lo, hi);
  };
  const int64_t max_blocks =
      config_.max_triangles > 0 ? std::max<int64_t>(1, config_.max_triangles / (2 * c * c)) : 0;
  selection_ =
      lod::select_error_clipmap(grid_, errors_, scale_, view, drawable_, config_.morph,
                                config_.cull ? lod::BlockFilter(visible) : lod::BlockFilter(), max_blocks);
  stats.select = selection_.stats;
  stats.cpu_ms = ms_since(t0);
  return stats;
}

namespace {
constexpr int64_t kAnchorStep = 1024;  // mip-0 samples: the anchor moves by whole steps
}  // namespace

ErrorClipmapRenderer::Batch ErrorClipmapRenderer::collect(const scene::Camera& camera,
                                                          const scene::Frustum& frustum,
                                                          std::vector<PatchInstance>& instances) {
  Batch batch;
  const double mps = scale_.meters_per_sample;
  const int64_t c = grid_.cells(), W = world_.width(), H = world_.height();
  const double skirt_m = min_height_m_ - kSkirtDepthM;
  // Instances grouped by side pattern (a bit per side toward a coarser neighbour): one
  // instanced draw per pattern; the walls in one more.
  std::array<std::vector<PatchInstance>, 16> by_pattern;
  std::vector<PatchInstance> walls;
  for (const lod::ClipmapBlock& b : selection_.blocks) {
    const int32_t l = b.id.level;
    const int64_t s = int64_t(1) << l;
    const int64_t x0 = int64_t(b.id.bx) * c * s, y0 = int64_t(b.id.by) * c * s;  // mip-0, world-relative
    if (x0 >= W - 1 || y0 >= H - 1) continue;                                    // wholly past the far edge
    const int64_t x1 = x0 + c * s, y1 = y0 + c * s;
    // The world's edges this block lies on (top, right, bottom, left): a wall hangs from each
    // (past the far edges the block's vertices are drawn at the edge).
    const std::array<bool, 4> edge{y0 == 0, x1 >= W - 1, y1 >= H - 1, x0 == 0};
    const bool on_edge = edge[0] || edge[1] || edge[2] || edge[3];
    const double rel_x = double(world_.x0 + x0) * mps - camera.x;
    const double rel_y = -(double(world_.y0 + y0) * mps - camera.y);
    const double spacing = double(s) * mps;
    if (config_.cull) {
      const double e = double(c) * spacing;
      const double lo_m = std::min(scale_.meters(errors_.min_height(l, b.id.bx, b.id.by)),
                                   on_edge ? scale_.height_offset + skirt_m : 1e300);
      const glm::vec3 lo(float(rel_x), float(rel_y - e), float(lo_m - camera.z));
      const glm::vec3 hi(float(rel_x + e), float(rel_y),
                         float(scale_.meters(errors_.max_height(l, b.id.bx, b.id.by)) - camera.z));
      if (scene::box_outside(frustum, lo, hi)) {
        ++batch.culled;
        continue;
      }
    }
    PatchInstance in{};
    in.patch[0] = int32_t(int64_t(b.id.bx) * c), in.patch[1] = int32_t(int64_t(b.id.by) * c), in.patch[2] = l;
    for (size_t k = 0; k < 4; ++k)
      in.edge_level[k] = b.lod.edge_level[k], in.edge_morph[k] = b.lod.edge_morph[k];
    in.misc[0] = b.lod.morph, in.misc[1] = float(rel_x), in.misc[2] = float(rel_y),
    in.misc[3] = float(spacing);
    const size_t pattern = size_t(b.lod.edge_level[0] | b.lod.edge_level[1] << 1 | b.lod.edge_level[2] << 2 |
                                  b.lod.edge_level[3] << 3);
    by_pattern[pattern].push_back(in);
    ++batch.blocks;
    for (int32_t side = 0; side < 4; ++side) {
      if (!edge[size_t(side)]) continue;
      PatchInstance w = in;
      w.patch[3] = side + 1;
      walls.push_back(w);
    }
  }
  const int32_t n = grid_.block_size;
  for (size_t p = 0; p <= by_pattern.size(); ++p) {
    const bool is_walls = p == by_pattern.size();
    const auto& list = is_walls ? walls : by_pattern[p];
    if (list.empty()) continue;
    PatchIndexBuffer::Range range;
    if (is_walls) {
      // A strip between the side's n vertices (0..n-1) and their feet (n..2n-1).
      range = indices_->get({-1, 0, 0, 0, 0}, [&] {
        PatchIndexBuffer::Triangles t;
        for (int32_t i = 0; i + 1 < n; ++i) {
          t.push_back({uint16_t(i), uint16_t(i + 1), uint16_t(n + i)});
          t.push_back({uint16_t(i + 1), uint16_t(n + i + 1), uint16_t(n + i)});
        }
        return t;
      });
    } else {
      const std::array<int8_t, 4> pattern{int8_t(p & 1), int8_t(p >> 1 & 1), int8_t(p >> 2 & 1),
                                          int8_t(p >> 3 & 1)};
      const std::array<int8_t, 5> key{0, pattern[0], pattern[1], pattern[2], pattern[3]};
      range = indices_->get(key, [&] { return lod::patch_triangles(patch_, 0, pattern); });
    }
    batch.draws.push_back({range, uint32_t(instances.size()), uint32_t(list.size())});
    instances.insert(instances.end(), list.begin(), list.end());
  }
  return batch;
}

int64_t ErrorClipmapRenderer::submit(const std::vector<Draw>& draws) {
  int64_t triangles = 0;
  for (const Draw& d : draws) {
    glDrawElementsInstancedBaseInstance(
        GL_TRIANGLES, GLsizei(d.range.count), GL_UNSIGNED_SHORT,
        reinterpret_cast<const void*>(uintptr_t(d.range.first) * sizeof(uint16_t)), GLsizei(d.count),
        d.first_instance);
    triangles += int64_t(d.range.count / 3) * d.count;
  }
  return triangles;
}

ErrorClipmapFrameStats ErrorClipmapRenderer::draw(const scene::Camera& camera, int32_t width,
                                                  int32_t height) {
  ErrorClipmapFrameStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  const WorldParams& p = source_->params();
  const double mps = scale_.meters_per_sample;
  const glm::mat4 vp = scene::view_projection(camera, width, height);
  std::vector<PatchInstance> instances;
  instances.reserve(selection_.blocks.size());
  const Batch view = collect(camera, scene::frustum_of(vp), instances);
  stats.blocks = view.blocks, stats.blocks_culled = view.culled;
  const auto sun = look_->shadow_frame(camera, p, min_height_m_, max_height_m_, config_.view_distance);
  Batch shadow;
  if (sun) shadow = collect(camera, scene::frustum_of(sun->light_view_proj), instances);
  instances_->upload(instances);

  // Positions the fragment stage shades by count from an anchor near the camera (world-relative
  // mip-0 samples, whole steps): small enough for float, exact in the material phases.
  const int64_t ax = floor_div(int64_t(std::floor(camera.x / mps)) - world_.x0, kAnchorStep) * kAnchorStep;
  const int64_t ay = floor_div(int64_t(std::floor(camera.y / mps)) - world_.y0, kAnchorStep) * kAnchorStep;
  ErrorClipmapFrameBlock e{};
  e.anchor[0] = int32_t(ax), e.anchor[1] = int32_t(ay);
  e.skirt_z = float(scale_.height_offset + min_height_m_ - kSkirtDepthM - camera.z);
  e.level_count = grid_.levels;
  for (int32_t l = 0; l < grid_.levels; ++l) {
    const Level& level = level_[size_t(l)];
    e.levels[l][0] = level.layer, e.levels[l][1] = int32_t(level.offset_x),
    e.levels[l][2] = int32_t(level.offset_y);
  }
  error_block_->write(0, e);
  TerrainShadingBlock shading =
      look_->frame(p, world_.x0 + ax, world_.y0 + ay, min_height_m_, max_height_m_, config_.view_distance);
  shading.change_on = change_texture_ && change_known_ ? 1 : 0;
  if (detail_) {
    detail_->fill(shading, p, world_.x0 + ax, world_.y0 + ay);
    detail_->bind();
  }
  const GeomipmapFrameBlock f =
      patch_frame(vp, {grid_.block_size, patch_.levels, int32_t(world_.width()), int32_t(world_.height())},
                  mps, scale_.meters_per_unit, scale_.height_offset, camera, min_height_m_, max_height_m_);
  frame_block_->write(0, f);
  stats.cpu_ms = ms_since(t0);

  error_block_->bind(kErrorClipmapFrameBinding);
  glBindVertexArray(vao_.get());
  glBindTextureUnit(0, levels_texture_.get());
  glBindTextureUnit(1, normals_texture_.get());
  if (change_texture_) glBindTextureUnit(kChangeUnit, change_texture_.get());
  // Normals and detail gradients written by compute must be visible to the draw.
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT);
  if (sun) {
    GeomipmapFrameBlock light = f;
    std::copy_n(&sun->light_view_proj[0][0], 16, light.view_proj);
    frame_block_->write(1, light);
    look_->render_shadow(*sun, shading, [&] {
      frame_block_->bind(0, 1);
      glUseProgram(shadow_program_.get());
      stats.shadow_triangles = submit(shadow.draws);
      stats.draw_calls += int32_t(shadow.draws.size());
    });
  }
  look_->bind(shading);
  frame_block_->bind(0, 0);
  glUseProgram(program_.get());
  const ReversedDepthTest depth_test;
  glViewport(0, 0, width, height);
  stats.triangles = submit(view.draws);
  stats.draw_calls += int32_t(view.draws.size());
  glBindVertexArray(0);
  glUseProgram(0);
  return stats;
}

ErrorClipmapUpdate ErrorClipmapRenderer::invalidate(const RectI& mip0_rect, const gpu::LevelFillSource* gpu) {
  ErrorClipmapUpdate u;
  const RectI r = mip0_rect.intersect(world_);
  if (r.empty()) return u;
  const auto t0 = std::chrono::steady_clock::now();
  const RectI local{r.x0 - world_.x0, r.y0 - world_.y0, r.x1 - world_.x0, r.y1 - world_.y0};
  // Each level's samples (and past the far edges those repeating an edge sample in the rect).
  std::vector<RectI> dirty(size_t(grid_.levels));
  int64_t samples = 0, normal_samples = 0;
  for (int32_t l = 0; l < grid_.levels; ++l) {
    if (!level_[size_t(l)].valid) continue;
    const int64_t s = int64_t(1) << l;
    // level_event.glsl computes the same rects on the GPU.
    RectI in_level{ceil_div(local.x0, s), ceil_div(local.y0, s), ceil_div(local.x1, s),
                   ceil_div(local.y1, s)};
    if (local.x1 == world_.width()) in_level.x1 = INT64_MAX / 4;
    if (local.y1 == world_.height()) in_level.y1 = INT64_MAX / 4;
    const RectI d = in_level.intersect(regions_[size_t(l)]);
    if (d.empty()) continue;
    dirty[size_t(l)] = d;
    samples += d.area();
    normal_samples += RectI{d.x0 - 4, d.y0 - 4, d.x1 + 4, d.y1 + 4}.intersect(drawable_[size_t(l)]).area();
  }
  // GPU to GPU where the cache holds every tile the rect reads: one block for the stamp, each
  // level's rect computed from it on the GPU, one dispatch for every level's samples and one
  // for their normals (gpu/level_fill.h).
  std::optional<size_t> on_gpu;
  if (gpu && fill_) {
    size_t places = 0;
    for (int32_t l = 0; l < grid_.levels; ++l) places += set_fill_level(l);
    const gpu::LevelTextures t{levels_texture_.get(),
                               change_texture_ && change_known_ ? change_texture_.get() : 0,
                               normals_texture_.get()};
    on_gpu = fill_->run(*gpu, r, grid_.levels, t, samples, normal_samples);
    if (on_gpu) {
      u.bytes_uploaded += *on_gpu + places;
      u.texels_on_gpu += samples;
    }
  }
  if (!on_gpu) {
    for (int32_t l = 0; l < grid_.levels; ++l) {
      const RectI& d = dirty[size_t(l)];
      if (d.empty()) continue;
      const int64_t texels = upload(l, d);
      u.texels += texels;
      // R16UI heights, the change layer's floats, and the normal pass's block.
      u.bytes_uploaded += size_t(texels) * (sizeof(uint16_t) + (change_texture_ ? sizeof(float) : 0)) +
                          sizeof(gpu::NormalBlock);
      update_normals(l, d);
    }
  }
  u.blocks = int32_t(
      errors_
          .update(
              grid_, [&](int32_t l, const RectI& rect, std::span<uint16_t> out) { read_level(l, rect, out); },
              local)
          .size());
  u.cpu_ms = ms_since(t0);
  return u;
}

void ErrorClipmapRenderer::invalidate_detail(const RectI& detail_rect) {
  if (detail_) detail_->invalidate(*source_, detail_rect);
}

size_t ErrorClipmapRenderer::gpu_bytes() const {
  // R16UI heights, RG16_SNORM normals and R16F change per layer.
  const size_t per_texel = 2 + 4 + (change_texture_ ? 2 : 0);
  return size_t(region_) * size_t(region_) * size_t(layers_) * per_texel + indices_->bytes() +
         instances_->bytes() + (detail_ ? detail_->gpu_bytes() : 0) + look_->gpu_bytes() +
         frame_block_->bytes() + error_block_->bytes();
}

}  // namespace loam::render
