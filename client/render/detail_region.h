// The detail layer around the camera, as both clipmap renderers shade it: size^2 detail samples
// (R8I offsets) in a torus (detail sample p at texel p mod size), brought to the camera by
// toroidal strips, and their gradient map (RG16F, meters per meter, central differences on
// the GPU: shaders/detail_gradient.comp.glsl) that perturbs the normals where a pixel covers
// less than about two detail samples (shaders/terrain_shading.glsl). Needs the GL 4.5 context
// current; not thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "client/render/clipmap_blocks.h"
#include "client/render/terrain_look.h"
#include "client/terrain/height_source.h"
#include "gpu/gl_handle.h"
#include "gpu/uniform_block.h"
#include "protocol/result.h"

namespace loam::render {

class DetailRegion {
 public:
  // `size`: samples per side, a power of two up to 4096 (the far-origin shifts are multiples
  // of it, as of the level tori).
  static Result<DetailRegion> create(int32_t size);
  // The renderers' form: none for a size of 0, else create(size); a negative size is refused.
  static Result<std::optional<DetailRegion>> create_unless_zero(int32_t size);

  // Centres the region on `center` (mip-0 samples, global grid) and uploads what came into it;
  // returns the texels uploaded.
  int64_t update(const terrain::HeightSource& source, double center_x, double center_y);
  // Detail samples of `detail_rect` (detail grid) changed in the source.
  void invalidate(const terrain::HeightSource& source, const RectI& detail_rect);
  // The block's detail fields, for positions counted from the anchor (global mip-0 sample).
  void fill(TerrainShadingBlock& block, const WorldParams& params, int64_t anchor_x, int64_t anchor_y) const;
  // Binds the offsets (kDetailOffsetsUnit) and the gradients (kDetailGradientUnit).
  void bind() const;
  int32_t size() const { return size_; }
  // Offsets and gradients.
  size_t gpu_bytes() const { return size_t(size_) * size_t(size_) * (1 + 4); }

 private:
  int64_t upload(const terrain::HeightSource& source, const RectI& rect);  // detail grid

  int32_t size_ = 0;
  gpu::GlTexture offsets_;   // R8I
  gpu::GlTexture gradient_;  // RG16F, meters per meter
  gpu::GlProgram gradient_program_;
  std::optional<gpu::UniformBuffer<DetailGradientBlock>> gradient_block_;
  bool valid_ = false;
  int64_t region_x_ = 0, region_y_ = 0;  // the region's first detail sample
  std::vector<int8_t> scratch_;
};

}  // namespace loam::render
