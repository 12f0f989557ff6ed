// The clipmap program's uniform blocks, shared by its vertex and fragment stages and mirrored
// by ClipmapFrameBlock and ClipmapLevelBlock (client/render/clipmap_blocks.h), which the
// renderer checks against the linked program at creation. The look (sun, materials, shadows,
// fog, the detail region) is terrain_shading_block.glsl's.

// Once per frame.
layout(std140, binding = 0) uniform ClipmapFrame {
  mat4 u_view_proj;
  ivec4 u_world_rel;            // the world's mip-0 samples minus the anchor, [x0, x1) x [y0, y1)
  vec2 u_cam_offset;            // camera minus the anchor, meters
  int u_n;
  int u_tex_size;
  int u_half_m;                 // 2m - 2: where the geomorph band ends, before subtracting it
  float u_meters_per_sample;
  float u_meters_per_unit;
  float u_height_base;          // height_offset minus the camera's z, meters
  float u_band;                 // geomorph band in level samples; 0: no morphing
  float u_skirt_z;              // camera-relative height of the skirt's foot
  int u_frame_pad0;
  int u_frame_pad1;
};

// Once per level (a range of one buffer bound per level's draws).
layout(std140, binding = 1) uniform ClipmapLevel {
  ivec2 u_tex_base;             // texel of local vertex (0, 0)
  ivec2 u_rel_origin;           // level origin minus the anchor, mip-0 samples
  ivec2 u_tex_base_coarse;      // the same for the next coarser level
  ivec2 u_rel_origin_coarse;
  vec2 u_viewer;                // LOD centre in level samples from the level origin
  int u_spacing;                // mip-0 samples per level sample
  int u_has_coarse;
  int u_detail_displace;        // add the detail offset under each vertex (finest level)
  int u_level_pad0;
  int u_level_pad1;
  int u_level_pad2;
};
