// The error-driven clipmap (client/lod/error_clipmap.h): blocks of every level drawn instanced,
// one draw per side pattern. gl_VertexID is the block-local vertex (y * block_size + x); its
// height is fetched from the block's level, a layer of the R16UI array texture holding each
// level's region toroidally (sample (x, y) at texel (x mod P, y mod P)), and geomorphed toward
// the next level as a geomipmap patch is (patch_morph.glsl): a block is a patch at local level
// 0 whose local level 1 is the next clipmap level.
layout(location = 0) in ivec4 a_block;       // origin (level samples), level, -
layout(location = 1) in ivec4 a_edge_level;  // per side: top (-y), right (+x), bottom (+y), left (-x)
layout(location = 2) in vec4 a_edge_morph;
layout(location = 3) in vec4 a_misc;         // morph, origin relative to the camera (render frame, m), spacing (m)

layout(binding = 0) uniform usampler2DArray g_levels;

out vec3 v_rel;
out float v_height;
out vec2 v_tex;         // the vertex's texel in its level's layer, unwrapped within the block
out vec2 v_tex_coarse;  // its position in the next level's layer
flat out int v_level;
out float v_alpha;

float patch_height(ivec2 local) {
  int torus = textureSize(g_levels, 0).x;
  ivec2 p = (a_block.xy + local) % torus;  // never negative: blocks start at the world's origin
  return float(texelFetch(g_levels, ivec3(p, a_block.z), 0).r);
}

void main() {
  int n = g_grid.x;
  ivec2 local = ivec2(gl_VertexID % n, gl_VertexID / n);
  float height = morphed_height(local, n, g_grid.y, 0, a_misc.x, a_edge_level, a_edge_morph);
  float z = g_scale.z + height * g_scale.y;
  v_rel = vec3(a_misc.y + float(local.x) * a_misc.w, a_misc.z - float(local.y) * a_misc.w, z);
  v_height = height * g_scale.y;
  int torus = textureSize(g_levels, 0).x;
  // Block origins are multiples of the block's cells (even): exact halves in the next level.
  v_tex = vec2(a_block.xy % torus + local);
  v_tex_coarse = vec2((a_block.xy / 2) % torus) + 0.5 * vec2(local);
  v_level = a_block.z;
  v_alpha = a_misc.x;
  gl_Position = g_view_proj * vec4(v_rel, 1.0);
}
