// Clipmap levels brought up to a stamp on the GPU, from the GPU tile cache (gpu/tile_pages.h):
// after a stamp the display stamped there, the levels take its samples GPU to GPU instead of
// reading them on the CPU and uploading them, and their normals follow. What crosses the bus
// for a stamp is one 64-byte block (its mip-0 rect, where the page table starts, the level
// count) and the page table of the tiles it reads. Each level's rect is computed on the GPU from
// that block and the level's place (shaders/level_event.glsl), which is written only when the
// level moves, and one dispatch covers every level: one fills (shaders/level_fill.comp.glsl:
// the pages sampled by the rule the CPU's level reads follow, decimation, and the edge samples
// past the world's far edges; the change layer moved by the height difference), one recomputes
// the FD4 normals around what changed (level_normals.comp.glsl, FROM_EVENT).
//
// Needs the GL 4.5 context current. Not thread-safe.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "gpu/gl_handle.h"
#include "gpu/normal_pass.h"
#include "gpu/tile_pages.h"
#include "gpu/uniform_block.h"
#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam::gpu {

// Mirrors LevelEvent (shaders/level_event.glsl, std140): one per stamp.
struct LevelEventBlock {
  int32_t rect0[4];   // mip-0 samples that changed, world-relative
  int32_t tiles[4];   // the page table's first tile (x, y), tiles per row
  int32_t world[4];   // the world's first global sample (x, y), its size (w, h)
  int32_t levels[4];  // the level count
};
static_assert(sizeof(LevelEventBlock) == 64);

// Mirrors LevelSlot (shaders/level_event.glsl, std430): one per level, rewritten when it moves.
struct LevelSlotBlock {
  int32_t region[4];    // level samples held (world-relative level grid); empty: not placed
  int32_t drawable[4];  // where its normals are defined
  int32_t texel[4];     // texel offset (x, y), layer, tex_size
  int32_t change[4];    // update the change layer (0/1), below level sample (x, y), stride 2^l
  float scale[4];       // meters per height unit
};
static_assert(sizeof(LevelSlotBlock) == 80);
// The normal pass's array element (LevelNormal, std430) is NormalBlock, member for member.
static_assert(sizeof(NormalBlock) == 80);

// What the fill reads: the world's mip-0 sample rect (global), and the cache's page of each
// mip-0 coarse tile, or none where the tile is not there or not what the levels show.
struct LevelFillSource {
  RectI world;
  const TilePages* pages = nullptr;
  std::function<std::optional<int32_t>(int32_t tx, int32_t ty)> page;
};

// The levels' array textures: heights (R16UI), change (R16F; 0: none), normals (RG16_SNORM).
struct LevelTextures {
  GLuint heights = 0, change = 0, normals = 0;
};

class LevelFill {
 public:
  // The most tiles one stamp's page table holds (a wider stamp is read on the CPU).
  static constexpr int64_t kMaxTiles = 256;

  // Room for `levels` levels.
  static Result<LevelFill> create(int32_t levels);

  // Level l's place (its LevelSlot, and its NormalBlock with rect unused); written only where
  // it changed. Returns the bytes written.
  size_t set_level(int32_t l, const LevelSlotBlock& slot, const NormalBlock& normals);
  // A stamp's fill: `rect0` (the world's global mip-0 samples that changed) over `levels`
  // levels, whose rects hold `samples` level samples and `normal_samples` normals in all (as
  // level_event.glsl computes them: they size the dispatches). Returns the bytes uploaded, or
  // nullopt (nothing done: read on the CPU) where a tile the rect reads has no page, or there
  // are more than kMaxTiles.
  std::optional<size_t> run(const LevelFillSource& source, const RectI& rect0, int32_t levels,
                            const LevelTextures& t, int64_t samples, int64_t normal_samples);

 private:
  GlProgram fill_program_, normal_program_;
  std::optional<UniformBuffer<LevelEventBlock>> event_;
  GlBuffer slots_, normal_slots_;  // std430 arrays, one element per level
  std::vector<LevelSlotBlock> slot_copy_;
  std::vector<NormalBlock> normal_copy_;
  std::vector<bool> written_;
  GlBuffer table_;
  size_t table_capacity_ = 0;
  std::vector<int32_t> scratch_;
};

}  // namespace loam::gpu
