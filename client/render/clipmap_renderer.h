// The GPU geometry-clipmap renderer: per-level height textures kept current toroidally, one
// shared index buffer (clipmap_mesh.h), vertex texture fetch at exact sample positions,
// transition-band geomorphing of positions (vertex shader) and normals (fragment shader),
// per-level FD4 normal maps from the shared normal pass (gpu/normal_pass.h), detail-layer
// normals near the camera, sun + sky lighting with height/slope materials, an earth skirt at
// the world's edge instead of the clamped terrain beyond it, per-piece frustum culling and
// camera-relative positions.
//
// Level l reads mip l (spacing 2^l mip-0 samples) from a HeightSource: a region of N x N
// samples, N = n + 2 * kLevelPad (the n vertex samples plus the neighbours FD4 normals at the
// coarser spacing reach), in an R16UI texture of P x P texels, P the power of two >= N.
// Mip-l sample (gx, gy) lives at texel (gx mod P, gy mod P), so a camera move uploads only the
// strips that came into view; the level's normal map (R32UI,
// packed like protocol/normal_map.h) is recomputed on the GPU for exactly those strips. The
// detail layer around the camera (detail_size^2 samples, R8I, toroidal alike) gets a gradient
// map (RG16F) that perturbs the normals where a pixel covers less than about two detail
// samples, and optionally displaces the finest level's vertices. Positions are formed relative
// to an integer anchor (the outermost level's origin, a multiple of 2^L samples) and the
// camera's offset from it, so nothing large reaches float: a view 10,000 km out renders as at
// home.
//
// World frame: x east (+gx), y along +gy (south in a DEM), z up, meters. Needs the GL 4.5
// context current; not thread-safe.
#pragma once

#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "client/lod/clipmap_mesh.h"
#include "client/render/clipmap_blocks.h"
#include "client/render/detail_region.h"
#include "client/render/terrain_look.h"
#include "client/scene/camera.h"
#include "client/scene/frustum.h"
#include "client/terrain/height_source.h"
#include "gpu/gl_handle.h"
#include "gpu/normal_pass.h"
#include "protocol/world.h"

namespace loam::render {

struct RendererConfig {
  int32_t n = 127;     // vertices per level side, 2^k - 1
  int32_t levels = 0;  // 0: enough to reach view_distance
  double view_distance = 4000.0;
  bool morph = true;                          // transition-band geomorphing
  bool cull = true;                           // per-piece frustum culling
  double min_height_m = 0, max_height_m = 0;  // material range; equal: from the source's mip
  int32_t detail_size = 512;                  // detail samples per side around the camera; 0: no detail
  bool detail_displacement = false;           // also displace the finest level's vertices by the detail
  TerrainLookConfig look;                     // materials, sun, shadows (terrain_look.h)
};

struct FrameStats {
  int64_t triangles = 0;  // non-degenerate triangles submitted
  int32_t draw_calls = 0;
  int32_t pieces_culled = 0;
  int64_t texels_uploaded = 0;   // by this frame's level update
  int64_t shadow_triangles = 0;  // drawn into the sun's shadow map (draw_calls include that pass)
  // The error-driven clipmap's screen-error budget met (px): its tolerance, or more where its
  // triangle cap bound. 0: the classic clipmap (no budget).
  double lod_budget_px = 0;
};

class ClipmapRenderer {
 public:
  static constexpr int32_t kLevelPad = 5;

  // `source` must outlive the renderer.
  static Result<std::unique_ptr<ClipmapRenderer>> create(const terrain::HeightSource& source,
                                                         const RendererConfig& config);

  // Brings the level textures to the camera (toroidal strips only) and draws into the bound
  // framebuffer's viewport of width x height. Depth test on; clears nothing.
  FrameStats render(const scene::Camera& camera, int32_t width, int32_t height);
  // The level-texture half of render(), for tests of the upload traffic.
  int64_t update_levels(const scene::Camera& camera);
  // Moves the sun (degrees: azimuth clockwise from north, elevation above the horizon); the
  // next frame's light and shadows follow.
  void set_sun(float azimuth_degrees, float elevation_degrees) {
    look_->set_sun(azimuth_degrees, elevation_degrees);
  }
  const TerrainLookConfig& look() const { return look_->config(); }
  // Samples of `mip0_rect` changed in the source: re-read them into every level holding them.
  void invalidate(const RectI& mip0_rect);
  // Detail samples of `detail_rect` (detail grid) changed in the source.
  void invalidate_detail(const RectI& detail_rect);

  // Reads level l's normal map over `rect` (level samples, inside its region; tests).
  std::vector<uint32_t> read_level_normals(int32_t l, const RectI& rect) const;
  // Level l's region of level samples (its texture's content).
  RectI level_region(int32_t l) const;

  int32_t levels() const { return levels_; }
  // The material textures' anisotropy in effect (config's, or auto's choice; 1 without materials).
  float anisotropy() const { return look_->anisotropy(); }
  // Bytes of GPU memory the renderer holds: level heights and normals, the detail region and
  // its gradients, the index buffer. Set by n and detail_size, never by the world's size.
  size_t gpu_bytes() const;
  const RendererConfig& config() const { return config_; }
  void set_morph(bool on) { config_.morph = on; }
  const std::vector<lod::LevelPlacement>& placements() const { return placed_; }

 private:
  struct Level {
    gpu::GlTexture texture;        // heights, R16UI
    gpu::GlTexture normals;        // R32UI, packed FD4 normals
    gpu::GlTexture change;         // R16F, meters against the initial terrain (materials)
    std::vector<uint16_t> mirror;  // N x N, the texture's content, for culling bounds
    bool valid = false;
    int64_t region_x = 0, region_y = 0;  // level-grid sample at the region's low corner
    RectI world;                         // the world's samples in this level's grid
  };
  ClipmapRenderer() = default;
  int64_t upload(Level& level, int32_t mip, const RectI& rect);  // rect in the level grid
  void update_normals(int32_t l, const RectI& uploaded);
  std::array<double, 2> lod_center_samples(const scene::Camera& camera) const;
  // Draws every level's pieces inside `frustum` with the bound program and frame block.
  void draw_levels(const scene::Camera& camera, const scene::Frustum& frustum, const glm::vec2& cam_offset,
                   FrameStats& stats);

  const terrain::HeightSource* source_ = nullptr;
  RendererConfig config_;
  int32_t levels_ = 0;
  int32_t region_size_ = 0;  // samples a level holds per side: n + 2 * kLevelPad
  int32_t tex_size_ = 0;     // its texture (the torus): the next power of two
  std::optional<lod::ClipmapMesh> mesh_;
  std::vector<Level> level_;
  std::vector<lod::LevelPlacement> placed_;
  gpu::GlBuffer indices_;
  gpu::GlVertexArray vao_;
  gpu::GlProgram program_, shadow_program_;
  std::optional<TerrainLook> look_;
  bool change_known_ = false;  // the source answered read_change at least once
  // The programs' uniform blocks (client/render/clipmap_blocks.h): one frame, one per level.
  std::optional<gpu::UniformBuffer<ClipmapFrameBlock>> frame_block_;
  std::optional<gpu::UniformBuffer<ClipmapLevelBlock>> level_block_;
  std::optional<gpu::LevelNormalPass> normal_pass_;
  std::optional<DetailRegion> detail_;
  std::vector<uint16_t> scratch_;
  std::vector<float> change_scratch_;
};

}  // namespace loam::render
