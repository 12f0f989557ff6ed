// The GPU geomipmap renderer: the level-of-detail scheme of client/lod/geomipmap.h drawn
// through GL, beside the clipmap renderer, from the same HeightSource, for the `lod` suite's
// comparison at a screen-error budget (and as the brute-force baseline: a budget of 0 draws
// every sample).
//
// The whole mip-0 world is one R16UI texture (the schemes compared here read the world at
// full resolution; the clipmap is the renderer whose memory is bounded). Each frame: levels
// and morphs chosen on the CPU (lod::select_lods), patches outside the frustum dropped
// (client/scene/frustum.h), then one draw per patch of the index buffer for its (level, side
// levels), with the patch's state in instanced attributes. Index buffers are built once per
// variant and cached. A stamp re-uploads its rect and recomputes the error bounds of exactly
// the patches it touches (invalidate()).
//
// World frame as the clipmap renderer's: x east (+gx), y along +gy, z up, meters, positions
// relative to the camera. Needs the GL 4.5 context current; not thread-safe.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "client/lod/geomipmap.h"
#include "client/render/clipmap_renderer.h"
#include "client/render/patch_draw.h"
#include "client/scene/camera.h"
#include "gpu/gl_handle.h"
#include "gpu/uniform_block.h"

namespace loam::render {

struct GeomipmapConfig {
  int32_t patch_size = 17;    // 2^k + 1
  double tolerance_px = 1.0;  // screen-space error budget; 0: every patch at full resolution
  bool morph = true;
  bool cull = true;
  // Leitao & Carmo's crack correction: false, by index update (sides adapt to a coarser
  // neighbour, lod::assign_sides); true, by skirts (every side at its own level, a skirt
  // hanging below each side, lod::skirt_depths).
  bool skirts = false;
};

struct GeomipmapFrameStats {
  int64_t triangles = 0;
  int32_t draw_calls = 0;
  int32_t patches_culled = 0;
  double cpu_ms = 0;  // level selection, culling and the per-patch upload
};

// What a stamp cost the scheme.
struct GeomipmapUpdate {
  int32_t patches = 0;  // error bounds recomputed
  double cpu_ms = 0;    // recomputation plus the texture upload
};

class GeomipmapRenderer {
 public:
  // `source` must outlive the renderer. Errors: a patch size geomipmapping does not take, a
  // world wider than the GL's texture size, a shader that does not build or whose block does
  // not match.
  static Result<std::unique_ptr<GeomipmapRenderer>> create(const terrain::HeightSource& source,
                                                           const GeomipmapConfig& config);

  // select() then draw(): the frame as a viewer sees it.
  GeomipmapFrameStats render(const scene::Camera& camera, int32_t width, int32_t height);
  // Chooses every patch's level and morph for `lod_camera` seeing a viewport `viewport_height`
  // pixels high; returns the CPU milliseconds it took.
  double select(const scene::Camera& lod_camera, int32_t viewport_height);
  // Draws the levels last selected into the bound framebuffer's viewport (depth test on;
  // clears nothing): a test or benchmark can hold them while the view moves.
  GeomipmapFrameStats draw(const scene::Camera& camera, int32_t width, int32_t height);
  // Samples of `mip0_rect` (the world's global grid) changed in the source.
  GeomipmapUpdate invalidate(const RectI& mip0_rect);

  const lod::GeomipmapGrid& grid() const { return grid_; }
  const lod::GeomipmapErrors& errors() const { return errors_; }
  // The levels the last render chose (row order), and with skirts their depths.
  const std::vector<lod::PatchLod>& lods() const { return lods_; }
  const std::vector<float>& skirt_depths() const { return skirt_depths_; }
  size_t gpu_bytes() const;

 private:
  GeomipmapRenderer() = default;

  const terrain::HeightSource* source_ = nullptr;
  GeomipmapConfig config_;
  RectI world_;  // the source's mip-0 samples (global grid)
  lod::HeightScale scale_;
  lod::GeomipmapGrid grid_;
  WorldHeights heights_;  // the CPU copy the errors read
  lod::GeomipmapErrors errors_;
  std::vector<lod::PatchLod> lods_;
  std::vector<float> skirt_depths_;  // per patch, with skirts

  gpu::GlTexture texture_;
  gpu::GlProgram program_;
  gpu::GlVertexArray vao_;
  std::optional<PatchIndexBuffer> indices_;
  std::optional<PatchInstanceBuffer> instances_;
  std::optional<gpu::UniformBuffer<GeomipmapFrameBlock>> frame_block_;
};

}  // namespace loam::render
