// The error-driven clipmap (client/lod/error_clipmap.h): blocks of every level drawn instanced,
// one draw per side pattern. gl_VertexID is the block-local vertex (y * block_size + x); its
// height is fetched from the block's level, a layer of the R16UI array texture holding each
// level's region toroidally (sample (x, y) at texel (x mod P, y mod P)), and geomorphed toward
// the next level as a geomipmap patch is (patch_morph.glsl): a block is a patch at local level
// 0 whose local level 1 is the next clipmap level. Levels that hold the whole world share
// layers (e_levels: layer and offset per level).
//
// The world ends in an earth wall: vertices past its far edges are drawn at the edge (with the
// edge's height, which the level repeats there), and a wall instance (a_block.w = side + 1)
// hangs a strip from a block's side on the world's edge, its top row the block's own edge
// vertices (the same morph and the same pull to the edge), its bottom row at the skirt's foot.
layout(location = 0) in ivec4 a_block;       // origin (level samples), level, wall side + 1 (0: the block)
layout(location = 1) in ivec4 a_edge_level;  // per side: top (-y), right (+x), bottom (+y), left (-x)
layout(location = 2) in vec4 a_edge_morph;
layout(location = 3) in vec4 a_misc;         // morph, origin relative to the camera (render frame, m), spacing (m)

layout(binding = 0) uniform usampler2DArray g_levels;

out vec3 v_rel;
out vec2 v_sample;      // mip-0 samples from the anchor
out float v_height;     // meters above the height offset's zero
out vec2 v_tex;         // the vertex's texel in its level's layer, unwrapped within the block
out vec2 v_tex_coarse;  // its position in the next level's layer
flat out int v_layer;         // the level's layer
flat out int v_layer_coarse;  // the next level's (-1: none)
out float v_alpha;
out float v_skirt;      // 1 on vertices at the skirt's foot
out float v_curv;       // the height's Laplacian at the level's spacing, 1/m (> 0: concave)

// The level's sample q (world-relative level samples), clamped to the world's samples: past the
// far edges the level repeats the edge, and nothing lies before the origin.
// The block's level's sample q (world-relative level samples, never negative).
float level_sample(ivec2 q) {
  ivec4 at = e_levels[a_block.z];
  int torus = textureSize(g_levels, 0).x;
  return float(texelFetch(g_levels, ivec3((q + at.yz) % torus, at.x), 0).r);
}

// The same clamped to the world's samples: past the far edges the level repeats the edge, and
// nothing lies before the origin.
float level_height(ivec2 q) {
  int s = 1 << a_block.z;
  return level_sample(clamp(q, ivec2(0), (g_grid.zw - 1) / s));
}

float patch_height(ivec2 local) { return level_sample(a_block.xy + local); }

void main() {
  int n = g_grid.x;
  int wall = a_block.w - 1;
  ivec2 local;
  bool foot = false;
  if (wall < 0) {
    local = ivec2(gl_VertexID % n, gl_VertexID / n);
  } else {
    int t = gl_VertexID % n, c = n - 1;
    foot = gl_VertexID >= n;
    local = wall == 0 ? ivec2(t, 0) : wall == 1 ? ivec2(c, t) : wall == 2 ? ivec2(t, c) : ivec2(0, t);
  }
  float height = morphed_height(local, n, g_grid.y, 0, a_misc.x, a_edge_level, a_edge_morph);
  int s = 1 << a_block.z;
  ivec2 q = a_block.xy + local;
  // Past the world's last sample: pulled to it.
  ivec2 inside = min(q * s, g_grid.zw - 1);
  vec2 off = vec2(inside - a_block.xy * s) / float(s);  // level samples from the block's origin
  float z = foot ? e_skirt_z : g_scale.z + height * g_scale.y;
  v_rel = vec3(a_misc.y + off.x * a_misc.w, a_misc.z - off.y * a_misc.w, z);
  v_sample = vec2(inside - e_anchor);
  v_height = height * g_scale.y;
  int torus = textureSize(g_levels, 0).x;
  ivec4 at = e_levels[a_block.z];
  // Block origins are multiples of the block's cells (even): exact halves in the next level.
  v_tex = vec2((a_block.xy + at.yz) % torus) + off;
  v_layer = at.x;
  v_layer_coarse = -1;
  v_tex_coarse = v_tex;
  if (a_block.z + 1 < e_level_count) {
    ivec4 coarse = e_levels[a_block.z + 1];
    v_tex_coarse = vec2((a_block.xy / 2 + coarse.yz) % torus) + 0.5 * off;
    v_layer_coarse = coarse.x;
  }
  v_alpha = a_misc.x;
  v_skirt = foot ? 1.0 : 0.0;
  float lap = level_height(q + ivec2(1, 0)) + level_height(q - ivec2(1, 0)) + level_height(q + ivec2(0, 1)) +
              level_height(q - ivec2(0, 1)) - 4.0 * level_height(q);
  v_curv = lap * g_scale.y / (a_misc.w * a_misc.w);
  gl_Position = g_view_proj * vec4(v_rel, 1.0);
}
