// The clipmap renderer's uniform blocks (shaders/clipmap_blocks.glsl and
// detail_gradient.comp.glsl; the look's is terrain_look.h's) as std140 C++ structs: the static_asserts pin
// the std140 offsets, and the member lists let gpu::verify_uniform_block check every name and offset against
// the linked program when the renderer is created.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "gpu/uniform_block.h"

namespace loam::render {

struct ClipmapFrameBlock {
  float view_proj[16];
  int32_t world_rel[4];
  float cam_offset[2];
  int32_t n, tex_size;
  int32_t half_m;
  float meters_per_sample, meters_per_unit, height_base;
  float band, skirt_z;
  int32_t pad0, pad1;
};
static_assert(offsetof(ClipmapFrameBlock, world_rel) == 64);
static_assert(offsetof(ClipmapFrameBlock, cam_offset) == 80);
static_assert(offsetof(ClipmapFrameBlock, half_m) == 96);
static_assert(offsetof(ClipmapFrameBlock, band) == 112);
static_assert(sizeof(ClipmapFrameBlock) == 128);

inline constexpr std::array kClipmapFrameMembers = {
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, view_proj, "u_view_proj"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, world_rel, "u_world_rel"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, cam_offset, "u_cam_offset"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, n, "u_n"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, tex_size, "u_tex_size"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, half_m, "u_half_m"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, meters_per_sample, "u_meters_per_sample"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, meters_per_unit, "u_meters_per_unit"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, height_base, "u_height_base"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, band, "u_band"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, skirt_z, "u_skirt_z"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, pad0, "u_frame_pad0"),
    LOAM_UNIFORM_MEMBER(ClipmapFrameBlock, pad1, "u_frame_pad1"),
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
