// The GPU renderer of Ulrich's adaptive quadtree (client/lod/quadtree.h), beside the clipmap and
// geomipmap renderers, for the `lod` suite. The CPU chooses the subdivision each frame and
// rebuilds the meshes of the blocks whose subdivision or morphs changed (vertices carry their
// drawn heights); each block is one vertex and index buffer and one draw, culled by the shared
// frustum test. The whole mip-0 world is held on the CPU (the errors and heights read it); a
// stamp recomputes the squares holding its samples and rebuilds their blocks.
//
// Shares the geomipmap program's frame block and fragment shading. Needs the GL 4.5 context
// current; not thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "bench/lod/geomipmap_renderer.h"
#include "client/lod/quadtree.h"
#include "client/render/clipmap_renderer.h"
#include "client/render/patch_draw.h"
#include "client/scene/camera.h"
#include "gpu/gl_handle.h"
#include "gpu/uniform_block.h"

namespace loam::render {

struct QuadtreeConfig {
  int32_t block_size = 64;
  double tolerance_px = 1.0;
  bool morph = true;
  bool cull = true;
  // Leitao & Carmo's tiled blocks with skirts: blocks restricted and drawn on their own, a skirt
  // below each block's border (lod::quadtree_skirt_depths). False: restricted across borders
  // (their crack correction by index update).
  bool skirts = false;
};

struct QuadtreeFrameStats {
  int64_t triangles = 0;
  int32_t draw_calls = 0;
  int32_t blocks_culled = 0;
  int32_t blocks_rebuilt = 0;
  int64_t squares_tested = 0;
  double cpu_ms = 0;  // subdivision, rebuilt meshes and their uploads
};

class QuadtreeRenderer {
 public:
  static Result<std::unique_ptr<QuadtreeRenderer>> create(const terrain::HeightSource& source,
                                                          const QuadtreeConfig& config);

  QuadtreeFrameStats render(const scene::Camera& camera, int32_t width, int32_t height);
  // Chooses the subdivision for `lod_camera` seeing a viewport `viewport_height` high and
  // rebuilds the changed blocks; returns the stats of that work (no drawing).
  QuadtreeFrameStats select(const scene::Camera& lod_camera, int32_t viewport_height);
  // Draws the meshes last built.
  QuadtreeFrameStats draw(const scene::Camera& camera, int32_t width, int32_t height);
  // Samples of `mip0_rect` changed in the source; returns the squares recomputed.
  int64_t invalidate(const RectI& mip0_rect);

  const lod::QuadtreeGrid& grid() const { return grid_; }
  const lod::QuadtreeState& state() const { return *state_; }

 private:
  struct Block {
    gpu::GlBuffer vertices, indices;
    uint32_t index_count = 0;
  };
  QuadtreeRenderer() = default;
  void rebuild(int32_t bx, int32_t by);

  const terrain::HeightSource* source_ = nullptr;
  QuadtreeConfig config_;
  RectI world_;
  lod::HeightScale scale_;
  lod::QuadtreeGrid grid_;
  WorldHeights heights_;
  lod::QuadtreeErrors errors_;
  std::optional<lod::QuadtreeState> state_;
  std::vector<uint8_t> stale_;       // blocks to rebuild whatever the subdivision (a stamp)
  std::vector<float> skirt_depths_;  // per block, with skirts: the depths their meshes were built with
  std::vector<Block> blocks_;
  std::vector<lod::QuadtreeVertex> vertex_scratch_;
  std::vector<std::array<uint32_t, 3>> triangle_scratch_;

  gpu::GlProgram program_;
  gpu::GlVertexArray vao_;
  gpu::GlBuffer origins_;
  std::optional<gpu::UniformBuffer<GeomipmapFrameBlock>> frame_block_;
};

}  // namespace loam::render
