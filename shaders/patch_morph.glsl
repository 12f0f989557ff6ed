// The drawn height of a patch's local vertex: client/lod/geomipmap.h's morphed_vertex_height,
// which the tests check on the CPU. Shared by the geomipmap and error-driven clipmap vertex
// stages; each supplies patch_height(local), the vertex's own height in height units.
float patch_height(ivec2 local);

// The union-jack split of the level cell at (x, y) (multiples of s): along its main diagonal?
bool main_diagonal(ivec2 q, int s) { return (((q.x / s) ^ (q.y / s)) & 1) == 0; }

// n: vertices per side; levels: the patch's levels; level, morph: the patch's own; per side
// (top -y, right +x, bottom +y, left -x) the side's level and morph.
float morphed_height(ivec2 local, int n, int levels, int level, float morph, ivec4 edge_level, vec4 edge_morph) {
  int c = n - 1;
  float own = patch_height(local);
  bool on_x = local.x == 0 || local.x == c, on_y = local.y == 0 || local.y == c;
  if (on_x && on_y) return own;  // a corner: a vertex of every level
  if (on_x || on_y) {
    int side = local.y == 0 ? 0 : local.x == c ? 1 : local.y == c ? 2 : 3;
    int e = edge_level[side];
    float m = edge_morph[side];
    int se = 1 << e;
    int t = on_y ? local.x : local.y;
    if (m > 0.0 && e + 1 < levels && t % (2 * se) != 0) {
      ivec2 step = on_y ? ivec2(se, 0) : ivec2(0, se);
      return own + m * (0.5 * (patch_height(local - step) + patch_height(local + step)) - own);
    }
    return own;
  }
  int s = 1 << level;
  ivec2 odd = (local / s) & 1;
  if (morph > 0.0 && level + 1 < levels && (odd.x | odd.y) != 0) {
    float target;
    if (odd.x == 0 || odd.y == 0) {
      target = 0.5 * (patch_height(local - odd * s) + patch_height(local + odd * s));
    } else if (main_diagonal(local - ivec2(s), 2 * s)) {
      target = 0.5 * (patch_height(local - ivec2(s)) + patch_height(local + ivec2(s)));
    } else {
      target = 0.5 * (patch_height(local + ivec2(s, -s)) + patch_height(local + ivec2(-s, s)));
    }
    return own + morph * (target - own);
  }
  return own;
}
