// Geomipmapping (client/lod/geomipmap.h): one patch per draw, its per-patch state in instanced
// attributes (the draw's base instance selects them). gl_VertexID is the local vertex
// (y * patch_size + x); its height is fetched from the whole world's R16UI texture at exactly
// that sample and blended toward the next coarser level's surface by the patch's morph factor
// (Wagner's geomorphing), or, on a border, by its side's level and morph, so two patches give a
// shared vertex the same height. Mirrors lod::displayed_height, which the tests check.
layout(location = 0) in ivec4 a_patch;       // origin (world samples), level, -
layout(location = 1) in ivec4 a_edge_level;  // per side: top (-y), right (+x), bottom (+y), left (-x)
layout(location = 2) in vec4 a_edge_morph;
layout(location = 3) in vec4 a_misc;         // morph, origin relative to the camera (render frame, m), -

layout(binding = 0) uniform usampler2D g_heights;

out vec3 v_rel;
out float v_height;

float h(ivec2 local) {
  ivec2 p = clamp(a_patch.xy + local, ivec2(0), g_grid.zw - 1);
  return float(texelFetch(g_heights, p, 0).r);
}

// The union-jack split of the level cell at (x, y) (multiples of s): along its main diagonal?
bool main_diagonal(ivec2 q, int s) { return (((q.x / s) ^ (q.y / s)) & 1) == 0; }

void main() {
  int n = g_grid.x, c = n - 1, levels = g_grid.y;
  ivec2 local = ivec2(gl_VertexID % n, gl_VertexID / n);
  float own = h(local);
  float height = own;
  bool on_x = local.x == 0 || local.x == c, on_y = local.y == 0 || local.y == c;
  if (on_x && on_y) {
    // A corner: a vertex of every level.
  } else if (on_x || on_y) {
    int side = local.y == 0 ? 0 : local.x == c ? 1 : local.y == c ? 2 : 3;
    int e = a_edge_level[side];
    float m = a_edge_morph[side];
    int se = 1 << e;
    int t = on_y ? local.x : local.y;
    if (m > 0.0 && e + 1 < levels && t % (2 * se) != 0) {
      ivec2 step = on_y ? ivec2(se, 0) : ivec2(0, se);
      height = own + m * (0.5 * (h(local - step) + h(local + step)) - own);
    }
  } else {
    int level = a_patch.z, s = 1 << level;
    float m = a_misc.x;
    ivec2 odd = (local / s) & 1;
    if (m > 0.0 && level + 1 < levels && (odd.x | odd.y) != 0) {
      float target;
      if (odd.x == 0 || odd.y == 0) {
        target = 0.5 * (h(local - odd * s) + h(local + odd * s));
      } else if (main_diagonal(local - ivec2(s), 2 * s)) {
        target = 0.5 * (h(local - ivec2(s)) + h(local + ivec2(s)));
      } else {
        target = 0.5 * (h(local + ivec2(s, -s)) + h(local + ivec2(-s, s)));
      }
      height = own + m * (target - own);
    }
  }
  // The last patches overhang the world by less than a patch: their heights repeat its edge
  // samples, as every read outside the world does.
  float z = g_scale.z + height * g_scale.y;
  v_rel = vec3(a_misc.y + float(local.x) * g_scale.x, a_misc.z - float(local.y) * g_scale.x, z);
  v_height = height * g_scale.y;
  gl_Position = g_view_proj * vec4(v_rel, 1.0);
}
