// The normal-map pass for a dirty rect of the coarse layer, on the GPU: clients regenerate
// the normals a stamp touched. Same FD4 gradients (4th-order one-sided stencils at the
// world's edges) and packing as protocol/normal_map.h, evaluated in double precision with
// the reference's operation order (shaders/normals.comp.glsl).
//
// Output: an R32UI texture of the whole coarse layer, one uint per sample, bits 0..15 nx and
// 16..31 ny as signed Q15 (round(n * 32767)), n = (-dh/dx, -dh/dy, 1) / |...|; a shader
// reads it with unpackSnorm2x16(texelFetch(...).r) and nz = sqrt(1 - nx^2 - ny^2). A stamp
// that changed samples R changes normals up to 4 samples around R (one-sided edge
// stencils reach 4 samples): pass normals_rect_for(R).
//
// Needs the GL 4.5 context current. Not thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "gpu/gl_handle.h"
#include "gpu/uniform_block.h"
#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam::gpu {

// The samples whose normals depend on samples in `changed` (global coarse samples),
// clipped to the world.
RectI normals_rect_for(const WorldParams& params, const RectI& changed);

// Mirrors the NormalParams block both normal passes read (shaders/fd4_normal.glsl, std140);
// checked member by member when a pass's program is built.
struct NormalBlock {
  int32_t rect[4];  // samples [x0, y0, x1, y1) to compute
  int32_t world_lo[2];
  int32_t world_size[2];
  int32_t region_lo[2];    // the level pass's region ...
  int32_t region_base[2];  // ... and its texel in the toroidal texture
  int32_t tex_size;
  int32_t pad0;
  double height_offset;
  double meters_per_unit;
  double spacing;
};
static_assert(sizeof(NormalBlock) == 80);

class NormalPass {
 public:
  static Result<std::unique_ptr<NormalPass>> create(const WorldParams& params);

  // Recomputes the normals of `rect` (global coarse samples; clipped to the world) from
  // `heights`, an R16UI texture of the whole coarse layer (texel (0, 0) = its first sample).
  void update(GLuint heights, const RectI& rect);

  GLuint texture() const { return normals_.get(); }
  // Reads packed normals of a rect back synchronously (tests, benchmarks).
  std::vector<uint32_t> read(const RectI& rect);

 private:
  NormalPass() = default;
  WorldParams params_;
  RectI world_;
  GlTexture normals_;
  GlProgram program_;
  UniformBuffer<NormalBlock> block_;
};

// The same FD4 normals for one clipmap level (client/render): the level's heights live in a
// toroidal R16UI texture (level sample p at texel p mod tex_size) and its normals in a
// toroidal RG16_SNORM texture (filterable) holding exactly the packed snorm16 values. Level
// samples are the world's samples at the level's spacing, so the finest level's normals equal
// NormalPass's bit for bit.
// The level pass's parameters (LevelNormalPass::update's arguments).
NormalBlock level_normal_block(int32_t tex_size, const RectI& region, const RectI& rect, const RectI& world,
                               const WorldParams& params, double spacing_m);

// The level pass after a stamp (define FROM_EVENT; gpu/level_fill.h): every level in one
// dispatch, each level's rect from shaders/level_event.glsl and its parameters (NormalBlocks)
// from an array.
Result<GlProgram> build_event_level_normal_program();

class LevelNormalPass {
 public:
  static Result<LevelNormalPass> create();
  // Recomputes the normals of `rect` (level samples) of a level holding `region` (tex_size^2
  // samples). Every stencil of rect must stay in the region: rect grown by 2, or by 4 at the
  // world's edges. `world` is the world's sample rect in the level's grid (one-sided stencils
  // at its edges), `spacing_m` meters per level sample.
  void update(GLuint heights, GLuint normals, int32_t tex_size, const RectI& region, const RectI& rect,
              const RectI& world, const WorldParams& params, double spacing_m);

 private:
  GlProgram program_;
  UniformBuffer<NormalBlock> block_;
};

}  // namespace loam::gpu
