// Clipmap shading: the level's FD4 normal map (filtered, blended toward the coarser level's in
// the geomorph band) and change layer, shaded by terrain_shading.glsl.
in vec3 v_rel;
in vec2 v_sample;
in float v_height;
in float v_alpha;
in float v_skirt;
in float v_curv;

layout(binding = 1) uniform sampler2D u_normals;         // this level, RG16_SNORM (nx, ny), filtered
layout(binding = 2) uniform sampler2D u_normals_coarse;  // the next coarser level
layout(binding = 5) uniform sampler2D u_change;          // this level, R16F meters against the initial terrain

out vec4 o_color;

// A level texture at level-local coordinates c: hardware bilinear, toroidal (GL_REPEAT) from
// the texel of local (0, 0).
vec4 level_texel(sampler2D t, ivec2 base, vec2 c) { return texture(t, (vec2(base) + c + 0.5) / float(u_tex_size)); }

void main() {
  vec2 local = (v_sample - vec2(u_rel_origin)) / float(u_spacing);
  vec2 nxy = level_texel(u_normals, u_tex_base, local).rg;
  if (u_has_coarse != 0 && v_alpha > 0.0) {
    vec2 c = (v_sample - vec2(u_rel_origin_coarse)) / float(2 * u_spacing);
    nxy = mix(nxy, level_texel(u_normals_coarse, u_tex_base_coarse, c).rg, v_alpha);
  }
  float change = t_change_on != 0 ? level_texel(u_change, u_tex_base, local).r : 0.0;
  o_color = shade_terrain(TerrainPoint(v_rel, v_sample, v_height, nxy, v_curv, change, v_skirt, v_alpha));
}
