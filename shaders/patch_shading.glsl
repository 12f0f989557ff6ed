// The patch renderers' shading (geomipmap.frag.glsl, error_clipmap.frag.glsl): height and slope
// colours and a sun with sky ambient, for a unit normal `n` (render frame, z up) at a height of
// `height_m` above the height offset. Alpha 1 marks terrain for the tests and the error
// evaluator.
vec4 shade_patch(vec3 n, float height_m) {
  float t = clamp((height_m - g_height_range.x) / max(g_height_range.y - g_height_range.x, 1e-3), 0.0, 1.0);
  vec3 albedo = mix(vec3(0.13, 0.21, 0.07), vec3(0.27, 0.25, 0.14), smoothstep(0.2, 0.5, t));
  albedo = mix(albedo, vec3(0.24, 0.22, 0.21), smoothstep(0.18, 0.40, 1.0 - n.z));
  albedo = mix(albedo, vec3(0.85, 0.88, 0.93), smoothstep(0.7, 0.8, t));
  float sun = max(dot(n, g_sun.xyz), 0.0);
  vec3 color = albedo * (0.25 + 0.15 * n.z + 0.9 * sun);
  return vec4(pow(color, vec3(1.0 / 2.2)), 1.0);
}
