// Error-driven clipmap shading: the FD4 normal of the block's level (its layer of an RG16_SNORM
// array texture, laid out like the heights, filtered), blended toward the next
// level's as far as the block morphs, and the level's change layer, shaded by
// terrain_shading.glsl as the clipmap's levels are: the same materials, dug earth, sun, shadows,
// detail normals and fog whatever the block's size.
in vec3 v_rel;
in vec2 v_sample;
in float v_height;
in vec2 v_tex;         // level texel coordinates (unwrapped within the block)
in vec2 v_tex_coarse;  // the same in the next level
flat in int v_layer;
flat in int v_layer_coarse;  // -1: no coarser level
in float v_alpha;      // the block's morph toward the next level
in float v_skirt;
in float v_curv;

layout(binding = 1) uniform sampler2DArray g_normals;
layout(binding = 5) uniform sampler2DArray g_change;  // R16F meters against the initial terrain

out vec4 o_color;

void main() {
  vec3 size = vec3(textureSize(g_normals, 0));
  vec2 nxy = texture(g_normals, vec3((v_tex + 0.5) / size.x, float(v_layer))).rg;
  if (v_alpha > 0.0 && v_layer_coarse >= 0) {
    vec2 coarse = texture(g_normals, vec3((v_tex_coarse + 0.5) / size.x, float(v_layer_coarse))).rg;
    nxy = mix(nxy, coarse, v_alpha);
  }
  float change = t_change_on != 0 ? texture(g_change, vec3((v_tex + 0.5) / size.x, float(v_layer))).r : 0.0;
  o_color = shade_terrain(TerrainPoint(v_rel, v_sample, v_height, nxy, v_curv, change, v_skirt, v_alpha));
}
