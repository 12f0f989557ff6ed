#include "client/render/detail_region.h"

#include <cmath>

#include "client/lod/clipmap_mesh.h"
#include "client/render/toroidal_upload.h"
#include "gpu/shader_library.h"

namespace loam::render {

namespace {
constexpr GLuint kDetailGradientBinding = 2;  // detail_gradient.comp.glsl's block
}  // namespace

Result<DetailRegion> DetailRegion::create(int32_t size) {
  if (size <= 0 || size > 4096 || (size & (size - 1)) != 0) {
    return make_error(ErrorCode::kInvalidArgument, "clipmap.detail_size",
                      "must be 0 or a power of two up to 4096");
  }
  DetailRegion d;
  d.size_ = size;
  d.offsets_ = gpu::make_texture(GL_TEXTURE_2D);
  glTextureStorage2D(d.offsets_.get(), 1, GL_R8I, size, size);
  // An integer texture with the default mipmapped min filter is incomplete and reads 0.
  glTextureParameteri(d.offsets_.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(d.offsets_.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  d.gradient_ = gpu::make_texture(GL_TEXTURE_2D);
  const GLuint g = d.gradient_.get();
  glTextureStorage2D(g, 1, GL_RG16F, size, size);
  // Filtered, and wrapping: the region is toroidal, so GL_REPEAT joins its seams.
  glTextureParameteri(g, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(g, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(g, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTextureParameteri(g, GL_TEXTURE_WRAP_T, GL_REPEAT);
  auto gradient = gpu::build_compute_program("detail_gradient.comp.glsl");
  if (!gradient) return gradient.error();
  d.gradient_program_ = std::move(*gradient);
  LOAM_TRY(gpu::verify_uniform_block(d.gradient_program_.get(), "DetailGradient", sizeof(DetailGradientBlock),
                                     kDetailGradientMembers));
  LOAM_TRY(gpu::verify_no_loose_uniforms(d.gradient_program_.get()));
  d.gradient_block_.emplace(1);
  return d;
}

Result<std::optional<DetailRegion>> DetailRegion::create_unless_zero(int32_t size) {
  if (size == 0) return std::optional<DetailRegion>();
  auto d = create(size);
  if (!d) return d.error();
  return std::optional<DetailRegion>(std::move(*d));
}

int64_t DetailRegion::upload(const terrain::HeightSource& source, const RectI& rect) {
  const int64_t n = size_;
  const int64_t texels = for_each_torus_piece(rect, n, [&](const RectI& piece, int64_t tx, int64_t ty) {
    scratch_.resize(size_t(piece.area()));
    source.read_detail(piece, scratch_);
    glTextureSubImage2D(offsets_.get(), 0, GLint(tx), GLint(ty), GLsizei(piece.width()),
                        GLsizei(piece.height()), GL_RED_INTEGER, GL_BYTE, scratch_.data());
  });
  // Gradients by central differences: recompute one sample around what changed.
  const RectI region{region_x_ + 1, region_y_ + 1, region_x_ + n - 1, region_y_ + n - 1};
  const RectI g = RectI{rect.x0 - 1, rect.y0 - 1, rect.x1 + 1, rect.y1 + 1}.intersect(region);
  if (!g.empty()) {
    const WorldParams& p = source.params();
    DetailGradientBlock b{};
    b.tex_size = GLint(n);
    b.region_lo[0] = GLint(region_x_), b.region_lo[1] = GLint(region_y_);
    b.region_base[0] = GLint(floor_mod(region_x_, n)), b.region_base[1] = GLint(floor_mod(region_y_, n));
    b.rect[0] = GLint(g.x0), b.rect[1] = GLint(g.y0), b.rect[2] = GLint(g.x1), b.rect[3] = GLint(g.y1);
    // Central differences span two samples: meters per unit over twice the spacing.
    b.scale = float(p.detail_meters_per_unit / (2.0 * p.detail_meters_per_sample()));
    gradient_block_->write(0, b);
    gradient_block_->bind(kDetailGradientBinding);
    glUseProgram(gradient_program_.get());
    glBindTextureUnit(0, offsets_.get());
    glBindImageTexture(1, gradient_.get(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RG16F);
    glDispatchCompute(GLuint((g.width() + 7) / 8), GLuint((g.height() + 7) / 8), 1);
  }
  return texels;
}

int64_t DetailRegion::update(const terrain::HeightSource& source, double center_x, double center_y) {
  const WorldParams& p = source.params();
  const int64_t n = size_;
  const int64_t rx = int64_t(std::floor(center_x * p.detail_factor)) - n / 2;
  const int64_t ry = int64_t(std::floor(center_y * p.detail_factor)) - n / 2;
  std::optional<std::array<int64_t, 2>> old;
  if (valid_) old = std::array<int64_t, 2>{region_x_, region_y_};
  const std::vector<RectI> strips = lod::toroidal_strips(old, {rx, ry}, n);
  valid_ = true;
  region_x_ = rx;
  region_y_ = ry;
  int64_t texels = 0;
  for (const RectI& s : strips) texels += upload(source, s);
  return texels;
}

void DetailRegion::invalidate(const terrain::HeightSource& source, const RectI& detail_rect) {
  if (!valid_) return;
  const int64_t n = size_;
  const RectI r = detail_rect.intersect({region_x_, region_y_, region_x_ + n, region_y_ + n});
  if (!r.empty()) upload(source, r);
}

void DetailRegion::fill(TerrainShadingBlock& b, const WorldParams& p, int64_t anchor_x,
                        int64_t anchor_y) const {
  const int64_t k = p.detail_factor;
  b.detail_on = 1;
  b.detail_size = size_;
  b.detail_factor = GLint(k);
  b.detail_rel_origin[0] = GLint(region_x_ - anchor_x * k);
  b.detail_rel_origin[1] = GLint(region_y_ - anchor_y * k);
  b.detail_base[0] = GLint(floor_mod(region_x_, int64_t(size_)));
  b.detail_base[1] = GLint(floor_mod(region_y_, int64_t(size_)));
  b.detail_meters_per_unit = float(p.detail_meters_per_unit);
}

void DetailRegion::bind() const {
  glBindTextureUnit(kDetailOffsetsUnit, offsets_.get());
  glBindTextureUnit(kDetailGradientUnit, gradient_.get());
}

}  // namespace loam::render
