// The clipmap program's uniform blocks, shared by its vertex and fragment stages and mirrored
// by ClipmapFrameBlock and ClipmapLevelBlock (client/render/clipmap_blocks.h), which the
// renderer checks against the linked program at creation.

// Once per frame.
layout(std140, binding = 0) uniform ClipmapFrame {
  mat4 u_view_proj;
  ivec4 u_world_rel;            // the world's mip-0 samples minus the anchor, [x0, x1) x [y0, y1)
  ivec2 u_detail_rel_origin;    // detail region's first sample minus the anchor, detail samples
  ivec2 u_detail_base;          // its texel
  vec3 u_sun_dir;               // render frame, unit, toward the sun
  float u_sea_level;            // meters above the height offset; below it is sea floor
  vec3 u_fog_color;             // linear
  float u_fog_density;          // per meter
  vec2 u_cam_offset;            // camera minus the anchor, meters
  vec2 u_height_range;          // material range, meters above the height offset
  int u_n;
  int u_tex_size;
  int u_half_m;                 // 2m - 2: where the geomorph band ends, before subtracting it
  int u_detail_on;
  int u_detail_size;
  int u_detail_factor;
  int u_debug_morph;            // tint by geomorph blend
  int u_frame_pad0;
  float u_meters_per_sample;
  float u_meters_per_unit;
  float u_height_base;          // height_offset minus the camera's z, meters
  float u_band;                 // geomorph band in level samples; 0: no morphing
  float u_skirt_z;              // camera-relative height of the skirt's foot
  float u_detail_meters_per_unit;
  float u_frame_pad1;
  float u_frame_pad2;
  mat4 u_light_view_proj;       // render frame -> the sun's shadow map (reversed depth)
  vec4 u_tex_phase;             // material texture phases of the anchor (scale A xy, scale B zw)
  vec2 u_macro_phase;           // ... of the slow variation
  float u_shadow_texel;         // 1 / shadow map side
  int u_shadows_on;
  int u_materials_on;
  int u_change_on;              // the change layer holds the change against the initial terrain
  int u_frame_pad3;
  int u_frame_pad4;
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
