#include "gpu/level_fill.h"

#include <algorithm>

#include "gpu/shader_library.h"

namespace loam::gpu {

namespace {

constexpr GLuint kTableBinding = 5;  // FillPages
constexpr GLuint kBlockBinding = 6;  // LevelFillParams

const UniformBlockMember kFillMembers[] = {
    LOAM_UNIFORM_MEMBER(LevelFillBlock, rect, "f_rect"),
    LOAM_UNIFORM_MEMBER(LevelFillBlock, world, "f_world"),
    LOAM_UNIFORM_MEMBER(LevelFillBlock, tiles, "f_tiles"),
    LOAM_UNIFORM_MEMBER(LevelFillBlock, texel, "f_texel"),
    LOAM_UNIFORM_MEMBER(LevelFillBlock, change, "f_change"),
    LOAM_UNIFORM_MEMBER(LevelFillBlock, scale, "f_scale"),
};

}  // namespace

Result<LevelFill> LevelFill::create() {
  auto program = build_compute_program("level_fill.comp.glsl");
  if (!program) return program.error();
  LOAM_TRY(verify_uniform_block(program->get(), "LevelFillParams", sizeof(LevelFillBlock), kFillMembers));
  LOAM_TRY(verify_no_loose_uniforms(program->get()));
  LevelFill f;
  f.program_ = std::move(*program);
  f.block_.emplace();
  return f;
}

std::optional<size_t> LevelFill::fill(const LevelFillTarget& target, const LevelFillSource& source,
                                      int32_t mip, const RectI& rect,
                                      std::optional<std::array<int64_t, 2>> change_below,
                                      double meters_per_unit) {
  if (rect.empty()) return size_t{0};
  if (!source.pages || source.world.empty()) return std::nullopt;
  const int64_t s = int64_t(1) << mip, W = source.world.width(), H = source.world.height();
  // The mip-0 samples the rect reads: its corners' positions (clamped to the world).
  auto pos = [&](int64_t q, int64_t lo, int64_t size) {
    return lo + std::clamp<int64_t>(q * s, 0, size - 1);
  };
  const RectI read{pos(rect.x0, source.world.x0, W), pos(rect.y0, source.world.y0, H),
                   pos(rect.x1 - 1, source.world.x0, W) + 1, pos(rect.y1 - 1, source.world.y0, H) + 1};
  const RectI tiles = tiles_overlapping(read);
  if (tiles.area() > kMaxTiles) return std::nullopt;
  // Every tile under the rect's span must be there, though a stride may skip some: the fill
  // is all or nothing.
  scratch_.assign(size_t(tiles.area()), -1);
  for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
    for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
      const auto page = source.page(int32_t(tx), int32_t(ty));
      if (!page) return std::nullopt;
      scratch_[size_t((ty - tiles.y0) * tiles.width() + (tx - tiles.x0))] = *page;
    }
  }
  const size_t table_bytes = scratch_.size() * sizeof(int32_t);
  if (table_bytes > table_capacity_) {
    table_ = make_buffer();
    table_capacity_ = std::max<size_t>(table_bytes, 64);
    glNamedBufferStorage(table_.get(), GLsizeiptr(table_capacity_), nullptr, GL_DYNAMIC_STORAGE_BIT);
  }
  glNamedBufferSubData(table_.get(), 0, GLsizeiptr(table_bytes), scratch_.data());
  LevelFillBlock b{};
  b.rect[0] = int32_t(rect.x0), b.rect[1] = int32_t(rect.y0), b.rect[2] = int32_t(rect.x1),
  b.rect[3] = int32_t(rect.y1);
  b.world[0] = int32_t(source.world.x0), b.world[1] = int32_t(source.world.y0), b.world[2] = int32_t(W),
  b.world[3] = int32_t(H);
  b.tiles[0] = int32_t(tiles.x0), b.tiles[1] = int32_t(tiles.y0), b.tiles[2] = int32_t(tiles.width()),
  b.tiles[3] = int32_t(s);
  b.texel[0] = target.offset_x, b.texel[1] = target.offset_y, b.texel[2] = target.layer,
  b.texel[3] = target.tex_size;
  const bool change = target.change != 0 && change_below.has_value();
  b.change[0] = change ? 1 : 0;
  if (change) {
    b.change[1] = int32_t(std::min<int64_t>((*change_below)[0], INT32_MAX));
    b.change[2] = int32_t(std::min<int64_t>((*change_below)[1], INT32_MAX));
  }
  b.scale[0] = float(meters_per_unit);
  block_->write(0, b);
  // The stamps' image stores into the pages must be visible to texelFetch, and earlier passes'
  // reads and writes of the level to these image loads and stores.
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  glUseProgram(program_.get());
  glBindTextureUnit(0, source.pages->texture());
  glBindImageTexture(0, target.heights, 0, GL_TRUE, 0, GL_READ_WRITE, GL_R16UI);
  if (change) glBindImageTexture(1, target.change, 0, GL_TRUE, 0, GL_READ_WRITE, GL_R16F);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kTableBinding, table_.get());
  block_->bind(kBlockBinding);
  glDispatchCompute(GLuint((rect.width() + 7) / 8), GLuint((rect.height() + 7) / 8), 1);
  // The normal pass and the draws read what was stored.
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  return table_bytes + sizeof b;
}

}  // namespace loam::gpu
