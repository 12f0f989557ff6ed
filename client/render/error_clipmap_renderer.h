// The error-driven clipmap renderer: the clipmap's level regions (mip l around the camera in a
// torus of P x P samples, one layer of an R16UI array texture per level, brought to the camera
// by toroidal strips as the clipmap renderer does; P is the configured region or less when the
// world's blocks need less, and a region stays inside the world; levels whose blocks fit in
// less than a layer are held whole, side by side in a shared layer) drawn as the blocks
// client/lod/error_clipmap.h selects for a screen-space error budget, instead of rings at fixed
// distances. GPU memory is set by P and the level count, never by the world's size; the CPU
// keeps the error bounds of the blocks inside the regions (8 bytes a block, computed as the
// regions move) and no heights: a 131 km world costs what a 4 km one does.
//
// Each level also holds its FD4 normal map (an RG16_SNORM layer, computed by the clipmap's level
// normal pass where heights entered or changed) and, with materials, its change layer (R16F,
// meters against the initial terrain); the fragment stage lights with them, blended toward the
// next level's as far as the block morphs, and blocks stay where normals are defined. The look
// is the clipmap renderer's (terrain_look.h: materials, dug earth, the sun's shadow map drawn
// from the same blocks, fog), with the detail layer's normals near the camera (detail_region.h)
// and an earth wall where the world ends.
//
// Each frame: the regions move with the camera (uploads), the blocks are chosen on the CPU,
// culled against the frustum (render/frustum.h), sorted by side pattern and drawn instanced,
// one draw per pattern (at most 16 with restricted sides). A stamp re-reads its rect into
// every level region holding it, from the display's GPU tile cache where it stamped there (one
// dispatch for every level's samples, one for their normals: gpu/level_fill.h) or on the CPU
// and uploaded, and recomputes the error bounds of exactly the blocks it touches
// (invalidate()).
//
// Level samples come from the source's mips, except beyond the world's far edges, where they
// repeat mip 0's edge samples (as the error pyramid assumes) rather than the mip's own.
//
// World frame as the clipmap renderer's: x east (+gx), y along +gy, z up, meters, positions
// relative to the camera. Needs the GL 4.5 context current; not thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "client/lod/error_clipmap.h"
#include "client/render/clipmap_renderer.h"
#include "client/render/detail_region.h"
#include "client/render/patch_draw.h"
#include "client/render/terrain_look.h"
#include "client/scene/camera.h"
#include "gpu/gl_handle.h"
#include "gpu/level_fill.h"
#include "gpu/normal_pass.h"
#include "gpu/uniform_block.h"

namespace loam::render {

struct ErrorClipmapConfig {
  int32_t block_size = 9;     // vertices per block side, 2^k + 1 (9: the fewest triangles per budget)
  int32_t region = 1024;      // at most this many level samples a level holds per side (>= 16 cells)
  int32_t levels = 0;         // 0: until a coarsest block spans the world and its region covers it
  double tolerance_px = 1.0;  // screen-space error budget
  // The most triangles the budget's blocks may take (0: no cap): past it the budget rises
  // (ErrorClipmapFrameStats::select.tolerance_px says to what). The restriction's blocks and
  // the world's walls come on top.
  int64_t max_triangles = 0;
  int32_t exact_levels = 3;  // error bounds exact up to this level (error_clipmap.h)
  bool morph = true;
  bool cull = true;
  double view_distance = 4000.0;  // where fog closes in, and the shadow map's reach (at most 3 km)
  int32_t detail_size = 512;      // detail samples per side around the camera; 0: no detail
  TerrainLookConfig look;
};

// shaders/error_clipmap_frame.glsl's ErrorClipmapFrame (std140).
struct ErrorClipmapFrameBlock {
  int32_t anchor[2];  // the mip-0 sample (world-relative) positions count from
  float skirt_z;      // camera-relative height of the skirt's foot
  int32_t level_count;
  int32_t levels[lod::kMaxClipmapLevels][4];  // per level: its layer, texel offset x, y, -
};
static_assert(offsetof(ErrorClipmapFrameBlock, levels) == 16);
static_assert(sizeof(ErrorClipmapFrameBlock) == 16 + 16 * lod::kMaxClipmapLevels);

inline constexpr std::array kErrorClipmapFrameMembers = {
    LOAM_UNIFORM_MEMBER(ErrorClipmapFrameBlock, anchor, "e_anchor"),
    LOAM_UNIFORM_MEMBER(ErrorClipmapFrameBlock, skirt_z, "e_skirt_z"),
    LOAM_UNIFORM_MEMBER(ErrorClipmapFrameBlock, level_count, "e_level_count"),
    LOAM_UNIFORM_MEMBER(ErrorClipmapFrameBlock, levels, "e_levels[0]"),
};

struct ErrorClipmapFrameStats {
  int64_t triangles = 0;         // blocks' and walls'
  int64_t shadow_triangles = 0;  // drawn into the sun's shadow map (draw_calls include that pass)
  int32_t draw_calls = 0;
  int32_t blocks = 0, blocks_culled = 0;
  int64_t texels_uploaded = 0;  // by this frame's region moves
  int64_t blocks_computed = 0;  // error bounds computed for blocks that entered the regions
  double cpu_ms = 0;            // region moves and uploads, error bounds, selection, culling, instance upload
  lod::ErrorClipmapSelectStats select;
};

struct ErrorClipmapUpdate {
  int32_t blocks = 0;         // error bounds recomputed
  int64_t texels = 0;         // level samples re-read and uploaded
  int64_t texels_on_gpu = 0;  // level samples filled from the GPU tile cache
  size_t bytes_uploaded = 0;  // level samples, or the fill's page table and constants
  double cpu_ms = 0;
};

class ErrorClipmapRenderer {
 public:
  // `source` must outlive the renderer. Errors: a block size or region the scheme does not
  // take, a shader that does not build or whose block does not match.
  static Result<std::unique_ptr<ErrorClipmapRenderer>> create(const terrain::HeightSource& source,
                                                              const ErrorClipmapConfig& config);

  // select() then draw().
  ErrorClipmapFrameStats render(const scene::Camera& camera, int32_t width, int32_t height);
  // Moves the level regions to `lod_camera` (uploading what entered them) and chooses the
  // blocks for a viewport `viewport_height` pixels high; with culling, blocks outside its
  // frustum (`viewport_width` wide, 0: twice the height) are not split.
  ErrorClipmapFrameStats select(const scene::Camera& lod_camera, int32_t viewport_height,
                                int32_t viewport_width = 0);
  // Draws the blocks last selected into the bound framebuffer's viewport (depth test on;
  // clears nothing).
  ErrorClipmapFrameStats draw(const scene::Camera& camera, int32_t width, int32_t height);
  // Samples of `mip0_rect` (the world's global grid) changed in the source. With `gpu` (the
  // display's GPU tile cache, holding those samples as the source does), each level takes
  // them GPU to GPU where every tile it reads has a page (gpu/level_fill.h); otherwise they are
  // read and uploaded. Only for samples the cache changed by stamping: the change layer moves
  // by the height difference there, which assumes the level held the previous samples.
  ErrorClipmapUpdate invalidate(const RectI& mip0_rect, const gpu::LevelFillSource* gpu = nullptr);
  // Detail samples of `detail_rect` (detail grid) changed in the source.
  void invalidate_detail(const RectI& detail_rect);
  // Moves the sun (degrees: azimuth clockwise from north, elevation above the horizon).
  void set_sun(float azimuth_degrees, float elevation_degrees) {
    look_->set_sun(azimuth_degrees, elevation_degrees);
  }
  const TerrainLookConfig& look() const { return look_->config(); }
  const ErrorClipmapConfig& config() const { return config_; }

  const lod::ClipmapBlockGrid& grid() const { return grid_; }
  const lod::ClipmapErrorPyramid& errors() const { return errors_; }
  const lod::ErrorClipmapSelection& selection() const { return selection_; }
  // Level l's region of level samples (world-relative: sample i is mip-0 sample i 2^l of the world).
  RectI region(int32_t l) const;
  // The same in the world's global grid at spacing 2^l, clipped to the world (the minimap and
  // the viewer's coverage read it).
  RectI level_region(int32_t l) const;
  // Where select() places the regions for `lod_camera` (its LOD centre), world-relative.
  std::vector<RectI> regions_for(const scene::Camera& lod_camera) const;
  // The same as level_region() gives them: a viewer subscribes their tiles before they are drawn.
  std::vector<RectI> level_regions_for(const scene::Camera& lod_camera) const;
  // Level l's sample (x, y) as the textures and the pyramid read it (world-relative level grid).
  void read_level(int32_t l, const RectI& rect, std::span<uint16_t> out) const;
  int32_t levels() const { return grid_.levels; }
  // Level samples held per side (the torus).
  int32_t region_size() const { return region_; }
  // Layers of the level textures: a level per layer, but levels that hold the whole world in
  // less than a layer share one (packed side by side).
  int32_t layers() const { return layers_; }
  // Level l's heights and change (meters) over `rect` (level samples inside its region), as
  // the textures hold them (tests).
  std::vector<uint16_t> read_level_heights(int32_t l, const RectI& rect) const;
  std::vector<float> read_level_change(int32_t l, const RectI& rect) const;
  // Level l's FD4 normals over `rect` (level samples inside its drawn part), packed like
  // protocol/normal_map.h (tests).
  std::vector<uint32_t> read_level_normals(int32_t l, const RectI& rect) const;
  // Level textures (heights, normals, change), the detail region, the look's textures, index and
  // instance buffers.
  size_t gpu_bytes() const;
  // The error pyramid.
  size_t cpu_bytes() const { return errors_.bytes(); }

 private:
  struct Level {
    bool valid = false;
    int64_t region_x = 0, region_y = 0;  // low corner of the region (level samples)
    // Where the level lives: its layer, and the texel of its sample (0, 0) there (a level held
    // whole beside others in a shared layer; 0 for a torus of its own). Level sample q is at
    // texel (q + offset) mod P.
    int32_t layer = 0;
    int64_t offset_x = 0, offset_y = 0;
  };
  struct LayerViews {
    gpu::GlTexture heights, normals;  // 2D views of one layer (the normal pass reads and writes 2D)
  };
  ErrorClipmapRenderer() = default;
  int64_t upload(int32_t l, const RectI& rect);
  // Level l's texels of `rect` in one of the level array textures (tests).
  template <class T>
  std::vector<T> read_level_texels(GLuint texture, GLenum format, GLenum type, int32_t l,
                                   const RectI& rect) const;
  // Level l's place for the GPU fill (written where it changed; returns the bytes written).
  size_t set_fill_level(int32_t l);
  // Instances of the selected blocks (and the walls on the world's edges) outside `frustum`'s
  // culling, grouped into one draw per pattern, appended to `instances`.
  struct Draw {
    PatchIndexBuffer::Range range;
    uint32_t first_instance = 0, count = 0;
  };
  struct Batch {
    std::vector<Draw> draws;
    int32_t blocks = 0, culled = 0;
  };
  Batch collect(const scene::Camera& camera, const scene::Frustum& frustum,
                std::vector<PatchInstance>& instances);
  // Draws `draws` with the bound program and vertex array; returns the triangles.
  static int64_t submit(const std::vector<Draw>& draws);
  // Level l's samples that blocks may use: its region less the 4-sample rim, on the sides where
  // the world goes on, whose normals the region cannot compute.
  RectI drawable(int32_t l) const;
  // `r` (level l's samples) moved to its texel coordinates (before the torus's wrap).
  RectI shifted(int32_t l, const RectI& r) const;
  void update_normals(int32_t l, const RectI& changed);
  lod::LodView lod_view(const scene::Camera& camera, int32_t viewport_width, int32_t viewport_height) const;
  // Level l's world-relative `local` in the global grid, clipped to the world.
  RectI to_global(int32_t l, const RectI& local) const;
  // Level samples level l's blocks reach, per axis: [0, extent).
  std::array<int64_t, 2> level_extent(int32_t l) const;
  // Level samples the selection's hierarchy may ask of level l: its share of the roots' blocks
  // (a root's children reach past the level's last block where the level count halves an odd
  // count). A level held whole holds these.
  std::array<int64_t, 2> hierarchy_extent(int32_t l) const;

  const terrain::HeightSource* source_ = nullptr;
  ErrorClipmapConfig config_;
  RectI world_;  // the source's mip-0 samples (global grid)
  lod::HeightScale scale_;
  lod::ClipmapBlockGrid grid_;
  lod::GeomipmapGrid patch_;
  lod::ClipmapErrorPyramid errors_;
  lod::ErrorClipmapSelection selection_;
  std::vector<Level> level_;
  std::vector<LayerViews> layer_views_;
  int32_t layers_ = 0;
  std::vector<RectI> regions_;
  std::vector<RectI> drawable_;  // per level, drawable()
  int32_t region_ = 0;           // the torus: level samples held per side
  double min_height_m_ = 0, max_height_m_ = 0;
  std::vector<uint16_t> scratch_;

  gpu::GlTexture levels_texture_;   // R16UI, region x region x layers
  gpu::GlTexture normals_texture_;  // RG16_SNORM, the same: FD4 normals as the clipmap renderer's
  gpu::GlTexture change_texture_;   // R16F, the same: meters against the initial terrain (materials)
  bool change_known_ = false;       // the source answered read_change at least once
  std::vector<float> change_scratch_, change_part_;
  std::optional<gpu::LevelNormalPass> normal_pass_;
  std::optional<gpu::LevelFill> fill_;
  std::optional<TerrainLook> look_;
  std::optional<DetailRegion> detail_;
  gpu::GlProgram program_, shadow_program_;
  std::optional<gpu::UniformBuffer<ErrorClipmapFrameBlock>> error_block_;
  gpu::GlVertexArray vao_;
  std::optional<PatchIndexBuffer> indices_;
  std::optional<PatchInstanceBuffer> instances_;
  std::optional<gpu::UniformBuffer<GeomipmapFrameBlock>> frame_block_;  // the view, and the sun's
};

}  // namespace loam::render
