// Geomipmapping (client/lod/geomipmap.h): one patch per draw, its per-patch state in instanced
// attributes (the draw's base instance selects them). gl_VertexID is the local vertex
// (y * patch_size + x); its height is fetched from the whole world's R16UI texture at exactly
// that sample and blended toward the next coarser level's surface by the patch's morph factor
// (Wagner's geomorphing), or, on a border, by its side's level and morph, so two patches give a
// shared vertex the same height (patch_morph.glsl). Ids past the grid are skirt vertices: a
// side's vertex lowered by the patch's skirt depth (tiled blocks with skirts).
layout(location = 0) in ivec4 a_patch;       // origin (world samples), level, skirt depth (height units)
layout(location = 1) in ivec4 a_edge_level;  // per side: top (-y), right (+x), bottom (+y), left (-x)
layout(location = 2) in vec4 a_edge_morph;
layout(location = 3) in vec4 a_misc;         // morph, origin relative to the camera (render frame, m), -

layout(binding = 0) uniform usampler2D g_heights;

out vec3 v_rel;
out float v_height;

float patch_height(ivec2 local) {
  ivec2 p = clamp(a_patch.xy + local, ivec2(0), g_grid.zw - 1);
  return float(texelFetch(g_heights, p, 0).r);
}

void main() {
  int n = g_grid.x, c = n - 1;
  ivec2 local = ivec2(gl_VertexID % n, gl_VertexID / n);
  float lowered = 0.0;
  if (gl_VertexID >= n * n) {
    // A skirt vertex (lod::skirt_triangles): side k / n's vertex at t = k % n, lowered.
    int k = gl_VertexID - n * n, side = k / n, t = k % n;
    local = side == 0 ? ivec2(t, 0) : side == 1 ? ivec2(c, t) : side == 2 ? ivec2(t, c) : ivec2(0, t);
    lowered = float(a_patch.w);
  }
  float height = morphed_height(local, n, g_grid.y, a_patch.z, a_misc.x, a_edge_level, a_edge_morph) - lowered;
  // The last patches overhang the world by less than a patch: their heights repeat its edge
  // samples, as every read outside the world does.
  float z = g_scale.z + height * g_scale.y;
  v_rel = vec3(a_misc.y + float(local.x) * g_scale.x, a_misc.z - float(local.y) * g_scale.x, z);
  v_height = height * g_scale.y;
  gl_Position = g_view_proj * vec4(v_rel, 1.0);
}
