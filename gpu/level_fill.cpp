#include "gpu/level_fill.h"

#include <algorithm>
#include <cstring>

#include "gpu/shader_library.h"

namespace loam::gpu {

namespace {

constexpr GLuint kFillTableBinding = 5;   // FillPages
constexpr GLuint kFillSlotBinding = 6;    // LevelSlots
constexpr GLuint kFillEventBinding = 7;   // LevelEvent
constexpr GLuint kFillNormalBinding = 9;  // LevelNormals

const UniformBlockMember kEventMembers[] = {
    LOAM_UNIFORM_MEMBER(LevelEventBlock, rect0, "e_rect0"),
    LOAM_UNIFORM_MEMBER(LevelEventBlock, tiles, "e_tiles"),
    LOAM_UNIFORM_MEMBER(LevelEventBlock, world, "e_world"),
    LOAM_UNIFORM_MEMBER(LevelEventBlock, levels, "e_levels"),
};

// One invocation per sample, 64 a group, in rows of at most 65535 groups.
void dispatch_flat(int64_t invocations) {
  if (invocations <= 0) return;
  const int64_t groups = (invocations + 63) / 64;
  const int64_t x = std::min<int64_t>(groups, 65535), y = (groups + x - 1) / x;
  glDispatchCompute(GLuint(x), GLuint(y), 1);
}

}  // namespace

Result<LevelFill> LevelFill::create(int32_t levels) {
  const std::string_view files[] = {"level_event.glsl", "level_fill.comp.glsl"};
  auto fill = build_compute_program_from(files);
  if (!fill) return fill.error();
  LOAM_TRY(verify_uniform_block(fill->get(), "LevelEvent", sizeof(LevelEventBlock), kEventMembers));
  LOAM_TRY(verify_no_loose_uniforms(fill->get()));
  auto normals = build_event_level_normal_program();
  if (!normals) return normals.error();
  LOAM_TRY(verify_uniform_block(normals->get(), "LevelEvent", sizeof(LevelEventBlock), kEventMembers));
  LevelFill f;
  f.fill_program_ = std::move(*fill);
  f.normal_program_ = std::move(*normals);
  const size_t n = size_t(std::max(levels, 1));
  f.event_.emplace();
  f.slots_ = make_buffer();
  glNamedBufferStorage(f.slots_.get(), GLsizeiptr(n * sizeof(LevelSlotBlock)), nullptr,
                       GL_DYNAMIC_STORAGE_BIT);
  f.normal_slots_ = make_buffer();
  glNamedBufferStorage(f.normal_slots_.get(), GLsizeiptr(n * sizeof(NormalBlock)), nullptr,
                       GL_DYNAMIC_STORAGE_BIT);
  f.slot_copy_.resize(n);
  f.normal_copy_.resize(n);
  f.written_.assign(n, false);
  return f;
}

size_t LevelFill::set_level(int32_t l, const LevelSlotBlock& slot, const NormalBlock& normals) {
  const size_t i = size_t(l);
  if (i >= written_.size()) return 0;
  size_t bytes = 0;
  if (!written_[i] || std::memcmp(&slot_copy_[i], &slot, sizeof slot) != 0) {
    glNamedBufferSubData(slots_.get(), GLintptr(i * sizeof slot), sizeof slot, &slot);
    slot_copy_[i] = slot;
    bytes += sizeof slot;
  }
  if (!written_[i] || std::memcmp(&normal_copy_[i], &normals, sizeof normals) != 0) {
    glNamedBufferSubData(normal_slots_.get(), GLintptr(i * sizeof normals), sizeof normals, &normals);
    normal_copy_[i] = normals;
    bytes += sizeof normals;
  }
  written_[i] = true;
  return bytes;
}

std::optional<size_t> LevelFill::run(const LevelFillSource& source, const RectI& rect0, int32_t levels,
                                     const LevelTextures& t, int64_t samples, int64_t normal_samples) {
  const RectI r = rect0.intersect(source.world);
  if (!source.pages || r.empty() || levels > int32_t(written_.size())) return std::nullopt;
  // Every level reads mip-0 positions inside the rect (past the far edges: the edge samples,
  // inside it too): its tiles, all of them there, or nothing is done.
  const RectI tiles = tiles_overlapping(r);
  if (tiles.area() > kMaxTiles) return std::nullopt;
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
  const RectI& w = source.world;
  LevelEventBlock e{};
  e.rect0[0] = int32_t(r.x0 - w.x0), e.rect0[1] = int32_t(r.y0 - w.y0), e.rect0[2] = int32_t(r.x1 - w.x0),
  e.rect0[3] = int32_t(r.y1 - w.y0);
  e.tiles[0] = int32_t(tiles.x0), e.tiles[1] = int32_t(tiles.y0), e.tiles[2] = int32_t(tiles.width());
  e.world[0] = int32_t(w.x0), e.world[1] = int32_t(w.y0), e.world[2] = int32_t(w.width()),
  e.world[3] = int32_t(w.height());
  e.levels[0] = levels;
  event_->write(0, e);
  event_->bind(kFillEventBinding);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kFillSlotBinding, slots_.get());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kFillTableBinding, table_.get());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kFillNormalBinding, normal_slots_.get());
  // The stamps' image stores into the pages must be visible to texelFetch, and earlier passes'
  // reads and writes of the levels to these loads and stores.
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  glUseProgram(fill_program_.get());
  glBindTextureUnit(0, source.pages->texture());
  glBindImageTexture(0, t.heights, 0, GL_TRUE, 0, GL_READ_WRITE, GL_R16UI);
  if (t.change) glBindImageTexture(1, t.change, 0, GL_TRUE, 0, GL_READ_WRITE, GL_R16F);
  dispatch_flat(samples);
  // Every level's heights stored before the normals read them (the stencils reach across).
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  glUseProgram(normal_program_.get());
  glBindTextureUnit(0, t.heights);
  glBindImageTexture(1, t.normals, 0, GL_TRUE, 0, GL_WRITE_ONLY, GL_RG16_SNORM);
  dispatch_flat(normal_samples);
  // The draws read what was stored.
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  return table_bytes + sizeof e;
}

}  // namespace loam::gpu
