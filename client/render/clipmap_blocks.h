// The clipmap renderer's uniform blocks (shaders/clipmap_blocks.glsl and
// detail_gradient.comp.glsl) as std140 C++ structs: the static_asserts pin the std140 offsets,
// and the member lists let gpu::verify_uniform_block check every name and offset against the
// linked program when the renderer is created.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "gpu/uniform_block.h"

namespace loam::render {

struct ClipmapFrameBlock {
  float view_proj[16];
  int32_t world_rel[4];
  int32_t detail_rel_origin[2], detail_base[2];
  float sun_dir[3], sea_level;
  float fog_color[3], fog_density;
  float cam_offset[2], height_range[2];
  int32_t n, tex_size, half_m, detail_on;
  int32_t detail_size, detail_factor, debug_morph, pad0;
  float meters_per_sample, meters_per_unit, height_base, band;
  float skirt_z, detail_meters_per_unit, pad1, pad2;
  float light_view_proj[16];  // render frame -> the sun's shadow map (client/scene/sun_shadow.h)
  float tex_phase[4];         // material texture phases of the anchor: scale A (xy), scale B (zw)
  float macro_phase[2], shadow_texel;
  int32_t shadows_on;
  int32_t materials_on, change_on, pad3, pad4;
};
static_assert(offsetof(ClipmapFrameBlock, world_rel) == 64);
static_assert(offsetof(ClipmapFrameBlock, detail_base) == 88);
static_assert(offsetof(ClipmapFrameBlock, sea_level) == 108);  // a float packs after a vec3
static_assert(offsetof(ClipmapFrameBlock, cam_offset) == 128);
static_assert(offsetof(ClipmapFrameBlock, n) == 144);
static_assert(offsetof(ClipmapFrameBlock, meters_per_sample) == 176);
static_assert(offsetof(ClipmapFrameBlock, light_view_proj) == 208);
static_assert(offsetof(ClipmapFrameBlock, macro_phase) == 288);
static_assert(offsetof(ClipmapFrameBlock, materials_on) == 304);
static_assert(sizeof(ClipmapFrameBlock) == 320);

inline constexpr std::array kClipmapFrameMembers = {
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, view_proj, "u_view_proj"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, world_rel, "u_world_rel"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, detail_rel_origin, "u_detail_rel_origin"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, detail_base, "u_detail_base"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, sun_dir, "u_sun_dir"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, sea_level, "u_sea_level"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, fog_color, "u_fog_color"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, fog_density, "u_fog_density"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, cam_offset, "u_cam_offset"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, height_range, "u_height_range"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, n, "u_n"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, tex_size, "u_tex_size"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, half_m, "u_half_m"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, detail_on, "u_detail_on"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, detail_size, "u_detail_size"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, detail_factor, "u_detail_factor"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, debug_morph, "u_debug_morph"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, pad0, "u_frame_pad0"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, meters_per_sample, "u_meters_per_sample"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, meters_per_unit, "u_meters_per_unit"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, height_base, "u_height_base"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, band, "u_band"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, skirt_z, "u_skirt_z"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, detail_meters_per_unit, "u_detail_meters_per_unit"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, pad1, "u_frame_pad1"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, pad2, "u_frame_pad2"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, light_view_proj, "u_light_view_proj"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, tex_phase, "u_tex_phase"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, macro_phase, "u_macro_phase"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, shadow_texel, "u_shadow_texel"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, shadows_on, "u_shadows_on"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, materials_on, "u_materials_on"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, change_on, "u_change_on"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, pad3, "u_frame_pad3"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, pad4, "u_frame_pad4"),
};

struct ClipmapLevelBlock {
  int32_t tex_base[2], rel_origin[2];
  int32_t tex_base_coarse[2], rel_origin_coarse[2];
  float viewer[2];
  int32_t spacing, has_coarse;
  int32_t detail_displace, pad0, pad1, pad2;
};
static_assert(offsetof(ClipmapLevelBlock, viewer) == 32);
static_assert(offsetof(ClipmapLevelBlock, detail_displace) == 48);
static_assert(sizeof(ClipmapLevelBlock) == 64);

inline constexpr std::array kClipmapLevelMembers = {
    LOAM_UNIFORM_MEMBER(ClipmapLevelBlock, tex_base, "u_tex_base"),
    LOAM_UNIFORM_MEMBER(ClipmapLevelBlock, rel_origin, "u_rel_origin"),
    LOAM_UNIFORM_MEMBER(ClipmapLevelBlock, tex_base_coarse, "u_tex_base_coarse"),
    LOAM_UNIFORM_MEMBER(ClipmapLevelBlock, rel_origin_coarse, "u_rel_origin_coarse"),
    LOAM_UNIFORM_MEMBER(ClipmapLevelBlock, viewer, "u_viewer"),
    LOAM_UNIFORM_MEMBER(ClipmapLevelBlock, spacing, "u_spacing"),
    LOAM_UNIFORM_MEMBER(ClipmapLevelBlock, has_coarse, "u_has_coarse"),
    LOAM_UNIFORM_MEMBER(ClipmapLevelBlock, detail_displace, "u_detail_displace"),
    LOAM_UNIFORM_MEMBER(ClipmapLevelBlock, pad0, "u_level_pad0"),
    LOAM_UNIFORM_MEMBER(ClipmapLevelBlock, pad1, "u_level_pad1"),
    LOAM_UNIFORM_MEMBER(ClipmapLevelBlock, pad2, "u_level_pad2"),
};

struct DetailGradientBlock {
  int32_t rect[4];
  int32_t region_lo[2], region_base[2];
  int32_t tex_size;
  float scale;
  int32_t pad0, pad1;
};
static_assert(offsetof(DetailGradientBlock, tex_size) == 32);
static_assert(sizeof(DetailGradientBlock) == 48);

inline constexpr std::array kDetailGradientMembers = {
    LOAM_UNIFORM_MEMBER(DetailGradientBlock, rect, "rect"),
    LOAM_UNIFORM_MEMBER(DetailGradientBlock, region_lo, "region_lo"),
    LOAM_UNIFORM_MEMBER(DetailGradientBlock, region_base, "region_base"),
    LOAM_UNIFORM_MEMBER(DetailGradientBlock, tex_size, "tex_size"),
    LOAM_UNIFORM_MEMBER(DetailGradientBlock, scale, "scale"),
    LOAM_UNIFORM_MEMBER(DetailGradientBlock, pad0, "pad0"),
    LOAM_UNIFORM_MEMBER(DetailGradientBlock, pad1, "pad1"),
};

}  // namespace loam::render
