// Geometry clipmap level: vertex (x, y) of the level's n x n grid is gl_VertexID; its height is
// fetched from the level's toroidal R16UI texture at exactly that sample (integer texelFetch,
// no filtering, no floor/round of a float coordinate). In the transition band the height and
// the FD4 normal blend toward the coarser level's triangle surface, which decimation makes
// readable from this level's texture: its samples are this level's even samples.
layout(binding = 0) uniform usampler2D u_heights;

uniform int u_n;
uniform int u_tex_size;
uniform ivec2 u_tex_base;      // texel of local vertex (0, 0)
uniform ivec2 u_rel_origin;    // level origin minus the anchor, mip-0 samples
uniform int u_spacing;         // mip-0 samples per level sample
uniform vec2 u_cam_offset;     // camera minus the anchor, meters
uniform float u_meters_per_sample;
uniform float u_meters_per_unit;
uniform float u_height_base;   // height_offset minus the camera's z, meters
uniform vec2 u_viewer;         // LOD centre in level samples from the level origin
uniform float u_band;          // geomorph band in level samples; 0: no morphing
uniform int u_half_m;          // 2m - 2: where the band ends, before subtracting it
uniform mat4 u_view_proj;

out vec3 v_rel;      // camera-relative position (render frame)
out vec3 v_normal;   // render frame
out float v_height;  // meters above the height offset's zero
out float v_alpha;

float q(ivec2 p) {
  // p >= -kLevelPad > -u_tex_size, so the sum is non-negative and % is well defined.
  ivec2 t = (u_tex_base + p + ivec2(u_tex_size)) % u_tex_size;
  return float(texelFetch(u_heights, t, 0).r);
}

// FD4 gradient (dh/dx, dh/dy) in meters per meter at stride k level samples.
vec2 grad(ivec2 p, int k) {
  ivec2 dx = ivec2(k, 0), dy = ivec2(0, k);
  float gx = q(p - 2 * dx) - 8.0 * q(p - dx) + 8.0 * q(p + dx) - q(p + 2 * dx);
  float gy = q(p - 2 * dy) - 8.0 * q(p - dy) + 8.0 * q(p + dy) - q(p + 2 * dy);
  return vec2(gx, gy) * u_meters_per_unit / (12.0 * float(k * u_spacing) * u_meters_per_sample);
}

void main() {
  ivec2 local = ivec2(gl_VertexID % u_n, gl_VertexID / u_n);
  float h = q(local);
  vec2 g = grad(local, 1);
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
    ivec2 a = local - odd, b = local + odd;
    h = mix(h, 0.5 * (q(a) + q(b)), alpha);
    g = mix(g, 0.5 * (grad(a, 2) + grad(b, 2)), alpha);
  }
  vec2 xy = vec2(u_rel_origin + local * u_spacing) * u_meters_per_sample - u_cam_offset;
  float z = u_height_base + h * u_meters_per_unit;
  // World y runs along +gy (south): the render frame flips it so x east, y north, z up is
  // right-handed and the terrain is not mirrored.
  v_rel = vec3(xy.x, -xy.y, z);
  v_normal = vec3(-g.x, g.y, 1.0);
  v_height = h * u_meters_per_unit;
  v_alpha = alpha;
  gl_Position = u_view_proj * vec4(v_rel, 1.0);
}
