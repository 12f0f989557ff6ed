// Clipmap level samples filled on the GPU from the GPU tile cache (gpu/tile_pages.h): after a
// stamp the display stamped there, the levels take its samples GPU to GPU instead of reading
// them on the CPU and uploading them. What crosses the bus is the page table of the tiles the
// rect reads and the pass's constants. shaders/level_fill.comp.glsl samples the pages by the
// rule the CPU's level reads follow (decimation; past the world's far edges, its edge samples)
// and moves the level's change layer by the height difference.
//
// Needs the GL 4.5 context current. Not thread-safe.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>

#include "gpu/gl_handle.h"
#include "gpu/tile_pages.h"
#include "gpu/uniform_block.h"
#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam::gpu {

// Mirrors LevelFillParams (shaders/level_fill.comp.glsl, std140).
struct LevelFillBlock {
  int32_t rect[4];
  int32_t world[4];
  int32_t tiles[4];
  int32_t texel[4];
  int32_t change[4];
  float scale[4];
};
static_assert(sizeof(LevelFillBlock) == 96);

// Where the filled samples go: a level of a toroidal R16UI array texture (and its R16F change
// layer), level sample q at texel (q + offset) mod tex_size of `layer`.
struct LevelFillTarget {
  GLuint heights = 0;
  GLuint change = 0;  // 0: none
  int32_t layer = 0;
  int32_t offset_x = 0, offset_y = 0;
  int32_t tex_size = 0;
};

// What the fill reads: the world's mip-0 sample rect (global), and the cache's page of each
// mip-0 coarse tile, or none where the tile is not there or not what the level shows.
struct LevelFillSource {
  RectI world;
  const TilePages* pages = nullptr;
  std::function<std::optional<int32_t>(int32_t tx, int32_t ty)> page;
};

class LevelFill {
 public:
  // The most tiles one fill reads (a larger rect is read on the CPU).
  static constexpr int64_t kMaxTiles = 256;

  static Result<LevelFill> create();

  // Fills level samples `rect` (world-relative level grid of mip `mip`) of `target` from
  // `source`; `change_below` (level samples, per axis) bounds where the change layer moves
  // (none: it does not). Returns the bytes uploaded, or nullopt (nothing done) where a tile the
  // rect reads has no page, or it reads more than kMaxTiles.
  std::optional<size_t> fill(const LevelFillTarget& target, const LevelFillSource& source, int32_t mip,
                             const RectI& rect, std::optional<std::array<int64_t, 2>> change_below,
                             double meters_per_unit);

 private:
  GlProgram program_;
  std::optional<UniformBuffer<LevelFillBlock>> block_;
  GlBuffer table_;
  size_t table_capacity_ = 0;
  std::vector<int32_t> scratch_;
};

}  // namespace loam::gpu
