// The terrain's look, shared by both clipmap renderers (shaders/terrain_shading.glsl): the
// material textures (splatted by height, slope and curvature, with exposed earth where the
// change layer says the ground was dug), the sun and its shadow map, sky ambient and distance
// fog. TerrainLook owns the GL side (material array, shadow map and its framebuffer, the
// TerrainShading block's buffer) and fills the block for a frame; the renderer that draws
// supplies its anchor (the integer mip-0 sample its positions count from), its height range
// and the depth pass the shadow map needs. Needs the GL 4.5 context current.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>

#include "client/scene/camera.h"
#include "client/scene/sun_shadow.h"
#include "gpu/gl_handle.h"
#include "gpu/uniform_block.h"
#include "protocol/result.h"
#include "protocol/world.h"

namespace loam::render {

struct TerrainLookConfig {
  // Materials: tiling detail textures splatted by height, slope and curvature, and exposed
  // earth where the terrain was dug or heaped (where the source knows the initial terrain).
  // Off: the flat colour bands only.
  bool materials = true;
  // Anisotropic filtering of the material textures (where the driver has it), 1..16; 1 is
  // plain trilinear. 0: 8 on a GPU (grazing views stay sharp, nearly free) and 1 on a software
  // rasterizer, which pays for every tap (llvmpipe: 7x the frame at 8, bench/results/clipmap.md).
  float anisotropy = 0.0f;
  // The sun's shadow map over a square of 2 x shadow_distance_m around the camera (0: the view
  // distance, at most 3 km), shadow_size texels per side. Off: no shadow pass.
  bool shadows = true;
  int32_t shadow_size = 2048;
  double shadow_distance_m = 0;
  // Degrees: azimuth clockwise from north, elevation above the horizon.
  float sun_azimuth_degrees = 135.0f, sun_elevation_degrees = 35.0f;
};

// shaders/terrain_shading_block.glsl's TerrainShading (std140).
struct TerrainShadingBlock {
  float light_view_proj[16];  // render frame -> the sun's shadow map (client/scene/sun_shadow.h)
  float tex_phase[4];         // material texture phases of the anchor: scale A (xy), scale B (zw)
  float sun_dir[3], sea_level;
  float fog_color[3], fog_density;
  float height_range[2], macro_phase[2];
  int32_t detail_rel_origin[2], detail_base[2];
  float meters_per_sample, shadow_texel;
  int32_t shadows_on, materials_on;
  int32_t change_on, detail_on, detail_size, detail_factor;
  float detail_meters_per_unit;
  int32_t debug_morph, pad0, pad1;
};
static_assert(offsetof(TerrainShadingBlock, tex_phase) == 64);
static_assert(offsetof(TerrainShadingBlock, sea_level) == 92);  // a float packs after a vec3
static_assert(offsetof(TerrainShadingBlock, height_range) == 112);
static_assert(offsetof(TerrainShadingBlock, detail_rel_origin) == 128);
static_assert(offsetof(TerrainShadingBlock, meters_per_sample) == 144);
static_assert(offsetof(TerrainShadingBlock, change_on) == 160);
static_assert(offsetof(TerrainShadingBlock, detail_meters_per_unit) == 176);
static_assert(sizeof(TerrainShadingBlock) == 192);

inline constexpr std::array kTerrainShadingMembers = {
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, light_view_proj, "t_light_view_proj"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, tex_phase, "t_tex_phase"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, sun_dir, "t_sun_dir"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, sea_level, "t_sea_level"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, fog_color, "t_fog_color"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, fog_density, "t_fog_density"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, height_range, "t_height_range"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, macro_phase, "t_macro_phase"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, detail_rel_origin, "t_detail_rel_origin"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, detail_base, "t_detail_base"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, meters_per_sample, "t_meters_per_sample"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, shadow_texel, "t_shadow_texel"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, shadows_on, "t_shadows_on"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, materials_on, "t_materials_on"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, change_on, "t_change_on"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, detail_on, "t_detail_on"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, detail_size, "t_detail_size"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, detail_factor, "t_detail_factor"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, detail_meters_per_unit, "t_detail_meters_per_unit"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, debug_morph, "t_debug_morph"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, pad0, "t_shading_pad0"),
    LOAM_UNIFORM_MEMBER(TerrainShadingBlock, pad1, "t_shading_pad1"),
};

// The texture units and block binding of shaders/terrain_shading.glsl (the change layer, unit
// 5, is the renderer's: each keeps its own per level).
inline constexpr GLuint kTerrainShadingBinding = 3;
inline constexpr GLuint kDetailOffsetsUnit = 3, kDetailGradientUnit = 4, kChangeUnit = 5, kMaterialsUnit = 6,
                        kShadowUnit = 7;

// Where the world ends, both renderers hang an earth wall this far below the lowest terrain.
inline constexpr double kSkirtDepthM = 30.0;

class TerrainLook {
 public:
  // Errors: an anisotropy or shadow size out of range, an incomplete shadow framebuffer.
  static Result<TerrainLook> create(const TerrainLookConfig& config);
  // Whether `program` declares TerrainShading as TerrainShadingBlock lays it out.
  static Status verify(GLuint program);

  // The frame's block: the sun, fog over `view_distance_m`, the sea level and the material range
  // (meters above the height offset), the material phases of the anchor (global mip-0 sample
  // anchor_x, anchor_y; exact however far it is). No shadow (render_shadow sets it), no detail
  // (DetailRegion::fill), no change layer: the renderer sets change_on.
  TerrainShadingBlock frame(const WorldParams& params, int64_t anchor_x, int64_t anchor_y,
                            double min_height_m, double max_height_m, double view_distance_m) const;
  // The sun's shadow frame for `camera` where a shadow pass is due (shadows on, the sun above
  // the horizon), over the heights of the material range (meters above the height offset).
  std::optional<scene::SunShadowFrame> shadow_frame(const scene::Camera& camera, const WorldParams& params,
                                                    double min_height_m, double max_height_m,
                                                    double view_distance_m) const;
  // Renders the shadow map: binds its framebuffer (viewport, cleared, reversed depth test,
  // slope-scaled offset), runs `draw_depth`, restores the draw framebuffer; then `block`
  // samples it.
  void render_shadow(const scene::SunShadowFrame& shadow, TerrainShadingBlock& block,
                     const std::function<void()>& draw_depth) const;
  // Uploads `block` and binds it, the material textures and the shadow map for the draw.
  void bind(const TerrainShadingBlock& block);

  void set_sun(float azimuth_degrees, float elevation_degrees);
  const TerrainLookConfig& config() const { return config_; }
  // The material textures' anisotropy in effect (config's, or auto's choice; 1 without materials).
  float anisotropy() const { return anisotropy_; }
  // The material textures and the shadow map.
  size_t gpu_bytes() const;

 private:
  glm::vec3 sun_dir() const;  // toward the sun, render frame, unit

  TerrainLookConfig config_;
  gpu::GlTexture materials_;  // RGBA8 2D array, one layer per Material, mipmapped
  float anisotropy_ = 1.0f;
  gpu::GlTexture shadow_map_;  // DEPTH32F, compared (sampler2DShadow)
  gpu::GlFramebuffer shadow_fbo_;
  std::optional<gpu::UniformBuffer<TerrainShadingBlock>> block_;
};

}  // namespace loam::render
