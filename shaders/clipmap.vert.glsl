// Geometry clipmap level: vertex (x, y) of the level's n x n grid is gl_VertexID; its height is
// fetched from the level's toroidal R16UI texture at exactly that sample (integer texelFetch,
// no filtering, no floor/round of a float coordinate). In the transition band the height
// blends toward the coarser level's triangle surface, which decimation makes readable from
// this level's texture: its samples are this level's even samples (normals blend in the
// fragment shader, from the two levels' normal maps). Vertices outside the world are pulled
// to its edge and down to the skirt's depth: the terrain ends in an earth wall, not in the
// clamped samples beyond it. The same stage draws the sun's shadow map (another view_proj).
layout(binding = 0) uniform usampler2D u_heights;
layout(binding = 3) uniform isampler2D u_detail;

out vec3 v_rel;      // camera-relative position (render frame)
out vec2 v_sample;   // mip-0 sample coordinates minus the anchor
out float v_height;  // meters above the height offset's zero
out float v_alpha;   // geomorph blend toward the coarser level
out float v_skirt;   // 1 on vertices pulled to the skirt
out float v_curv;    // the height's Laplacian at this level's spacing, 1/m (> 0: concave)

float q(ivec2 p) {
  // p >= -kLevelPad > -u_tex_size, so the sum is non-negative and % is well defined.
  ivec2 t = (u_tex_base + p + ivec2(u_tex_size)) % u_tex_size;
  return float(texelFetch(u_heights, t, 0).r);
}

void main() {
  ivec2 local = ivec2(gl_VertexID % u_n, gl_VertexID / u_n);
  float h = q(local);
  float alpha = 0.0;
  if (u_band > 0.0) {
    bool edge = local.x == 0 || local.y == 0 || local.x == u_n - 1 || local.y == u_n - 1;
    vec2 d2 = abs(vec2(local) - u_viewer);
    alpha = edge ? 1.0 : clamp((max(d2.x, d2.y) - (float(u_half_m) - u_band)) / u_band, 0.0, 1.0);
  }
  if (alpha > 0.0) {
    // The coarser quad is split along (x, y)-(x+1, y+1) like every quad: an odd vertex lies on
    // the coarse edge or diagonal between local - odd and local + odd.
    ivec2 odd = local & 1;
    h = mix(h, 0.5 * (q(local - odd) + q(local + odd)), alpha);
  }
  ivec2 s = u_rel_origin + local * u_spacing;
  ivec2 inside = clamp(s, u_world_rel.xy, u_world_rel.zw - 1);
  bool skirt = inside != s;
  float z = u_height_base + h * u_meters_per_unit;
  if (u_detail_displace != 0 && !skirt) {
    ivec2 dp = s * t_detail_factor - t_detail_rel_origin;
    if (all(greaterThanEqual(dp, ivec2(0))) && all(lessThan(dp, ivec2(t_detail_size)))) {
      ivec2 t = (t_detail_base + dp) % t_detail_size;
      z += float(texelFetch(u_detail, t, 0).r) * t_detail_meters_per_unit;
    }
  }
  if (skirt) z = u_skirt_z;
  vec2 xy = vec2(inside) * u_meters_per_sample - u_cam_offset;
  // World y runs along +gy (south): the render frame flips it so x east, y north, z up is
  // right-handed and the terrain is not mirrored.
  v_rel = vec3(xy.x, -xy.y, z);
  v_sample = vec2(s);
  v_height = h * u_meters_per_unit;
  v_alpha = alpha;
  v_skirt = skirt ? 1.0 : 0.0;
  // Curvature at the level's own scale: valleys and crater floors gather sediment, ridges
  // and rims shed it (the materials' splatting reads it).
  float lap = q(local + ivec2(1, 0)) + q(local - ivec2(1, 0)) + q(local + ivec2(0, 1)) + q(local - ivec2(0, 1)) -
              4.0 * q(local);
  float step_m = float(u_spacing) * u_meters_per_sample;
  v_curv = lap * u_meters_per_unit / (step_m * step_m);
  gl_Position = u_view_proj * vec4(v_rel, 1.0);
}
