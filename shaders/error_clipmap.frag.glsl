// Error-driven clipmap shading: the FD4 normal of the block's level (one layer of an RG16_SNORM
// array texture per level, toroidal like the heights, filtered), blended toward the next
// level's as far as the block morphs, shaded by patch_shading.glsl: a smooth surface whatever
// the block's size, as the clipmap renderer's normal maps give.
in vec3 v_rel;
in float v_height;
in vec2 v_tex;         // level texel coordinates (unwrapped within the block)
in vec2 v_tex_coarse;  // the same in the next level
flat in int v_level;
in float v_alpha;      // the block's morph toward the next level

layout(binding = 1) uniform sampler2DArray g_normals;

out vec4 o_color;

void main() {
  vec3 size = vec3(textureSize(g_normals, 0));
  vec2 nxy = texture(g_normals, vec3((v_tex + 0.5) / size.x, float(v_level))).rg;
  if (v_alpha > 0.0 && float(v_level + 1) < size.z) {
    vec2 coarse = texture(g_normals, vec3((v_tex_coarse + 0.5) / size.x, float(v_level + 1))).rg;
    nxy = mix(nxy, coarse, v_alpha);
  }
  // The normal maps hold (nx, ny) in the world's frame (y along +gy); the render frame's y is
  // north.
  vec3 n = normalize(vec3(nxy.x, -nxy.y, sqrt(max(1.0 - dot(nxy, nxy), 0.0))));
  o_color = shade_patch(n, v_height);
}
