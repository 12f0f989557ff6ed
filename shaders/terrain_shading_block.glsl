// The terrain look's uniform block (shaders/terrain_shading.glsl), shared by the clipmap and the
// error-driven clipmap programs and mirrored by TerrainShadingBlock (client/render/
// terrain_look.h), which each renderer checks against its linked program at creation. Every
// position it speaks of is in mip-0 samples from the drawing renderer's anchor (an integer
// sample, so nothing large reaches float).
layout(std140, binding = 3) uniform TerrainShading {
  mat4 t_light_view_proj;        // render frame -> the sun's shadow map (reversed depth)
  vec4 t_tex_phase;              // material texture phases of the anchor (scale A xy, scale B zw)
  vec3 t_sun_dir;                // render frame, unit, toward the sun
  float t_sea_level;             // meters above the height offset; below it is sea floor
  vec3 t_fog_color;              // linear
  float t_fog_density;           // per meter
  vec2 t_height_range;           // material range, meters above the height offset
  vec2 t_macro_phase;            // material phase of the slow variation
  ivec2 t_detail_rel_origin;     // the detail region's first sample minus the anchor, detail samples
  ivec2 t_detail_base;           // its texel
  float t_meters_per_sample;
  float t_shadow_texel;          // 1 / shadow map side
  int t_shadows_on;
  int t_materials_on;
  int t_change_on;               // the change layer holds the change against the initial terrain
  int t_detail_on;
  int t_detail_size;             // detail region side (texels)
  int t_detail_factor;           // detail samples per mip-0 sample
  float t_detail_meters_per_unit;
  int t_debug_morph;             // tint by geomorph blend
  int t_shading_pad0;
  int t_shading_pad1;
};
