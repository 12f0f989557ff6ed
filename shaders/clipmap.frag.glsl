// Terrain shading: normals from the level's FD4 normal map (filtered, blended toward the
// coarser level's in the geomorph band), perturbed by the detail layer's gradient near the
// camera; height/slope materials (sand, grass, dry grass, rock, snow, sea floor); a sun with
// a sky hemisphere ambient; distance fog into the sky colour; flat-shaded earth on the skirt.
// Alpha is 1 on terrain so a background pixel (alpha 0 after the clear) is detectable in tests.
in vec3 v_rel;
in vec2 v_sample;
in float v_height;
in float v_alpha;
in float v_skirt;

layout(binding = 1) uniform sampler2D u_normals;         // this level, RG16_SNORM (nx, ny), filtered
layout(binding = 2) uniform sampler2D u_normals_coarse;  // the next coarser level
layout(binding = 4) uniform sampler2D u_detail_gradient;  // RG16F, meters per meter

out vec4 o_color;

// (nx, ny) of a level's normal map at level-local coordinates c: hardware bilinear, toroidal
// (GL_REPEAT) from the texel of local (0, 0).
vec2 normal_xy(sampler2D t, ivec2 base, vec2 c) { return texture(t, (vec2(base) + c + 0.5) / float(u_tex_size)).rg; }

void main() {
  // Derivatives in uniform control flow only: the skirt's flat normal, the detail footprint.
  vec3 face = cross(dFdx(v_rel), dFdy(v_rel));
  vec2 dc = v_sample * float(u_detail_factor) - vec2(u_detail_rel_origin);
  float footprint = max(length(dFdx(dc)), length(dFdy(dc)));
  vec3 n;
  bool wall = v_skirt > 1e-3;
  if (wall) {
    n = normalize(face);
    if (dot(n, v_rel) > 0.0) n = -n;
  } else {
    vec2 nxy = normal_xy(u_normals, u_tex_base, (v_sample - vec2(u_rel_origin)) / float(u_spacing));
    if (u_has_coarse != 0 && v_alpha > 0.0) {
      vec2 c = (v_sample - vec2(u_rel_origin_coarse)) / float(2 * u_spacing);
      nxy = mix(nxy, normal_xy(u_normals_coarse, u_tex_base_coarse, c), v_alpha);
    }
    // The terrain's gradient, plus the detail layer's where a pixel resolves it.
    vec2 g = -nxy / sqrt(max(1.0 - dot(nxy, nxy), 1e-6));
    if (u_detail_on != 0) {
      // Gradients exist one sample inside the region and filtering reads one more: fade in
      // from two samples in, so nothing outside the region (stale wrap-around) contributes.
      float border = min(min(dc.x, dc.y), min(float(u_detail_size) - dc.x, float(u_detail_size) - dc.y)) - 2.0;
      float w = clamp(border / 16.0, 0.0, 1.0) * clamp(2.0 - footprint, 0.0, 1.0);
      if (w > 0.0) g += w * texture(u_detail_gradient, (vec2(u_detail_base) + dc + 0.5) / float(u_detail_size)).rg;
    }
    // World y runs south; the render frame's north.
    n = normalize(vec3(-g.x, g.y, 1.0));
  }
  float slope = 1.0 - n.z;  // 0 flat, 1 vertical
  float land = max(u_height_range.y - u_sea_level, 1e-3);
  float t = clamp((v_height - u_sea_level) / land, 0.0, 1.0);
  const vec3 sand = vec3(0.50, 0.44, 0.30), grass = vec3(0.13, 0.21, 0.07), dry = vec3(0.27, 0.25, 0.14);
  const vec3 rock = vec3(0.24, 0.22, 0.21), snow = vec3(0.85, 0.88, 0.93);
  const vec3 shallow = vec3(0.10, 0.28, 0.30), deep = vec3(0.02, 0.07, 0.16);
  const vec3 earth = vec3(0.20, 0.14, 0.09), earth_deep = vec3(0.11, 0.08, 0.06);
  vec3 albedo = mix(sand, grass, smoothstep(0.01, 0.05, t));
  albedo = mix(albedo, dry, smoothstep(0.25, 0.50, t));
  albedo = mix(albedo, rock, smoothstep(0.18, 0.40, slope));
  albedo = mix(albedo, snow, smoothstep(0.62, 0.75, t) * (1.0 - smoothstep(0.30, 0.55, slope)));
  if (v_height < u_sea_level) {
    float depth = (u_sea_level - v_height) / max(u_sea_level - u_height_range.x, 1e-3);
    albedo = mix(shallow, deep, smoothstep(0.0, 0.35, depth));
  }
  if (wall) albedo = mix(earth, earth_deep, v_skirt);
  float sun = max(dot(n, u_sun_dir), 0.0);
  vec3 sky = mix(vec3(0.18, 0.16, 0.14), vec3(0.42, 0.52, 0.70), 0.5 + 0.5 * n.z);
  vec3 c = albedo * (sun * vec3(1.10, 1.00, 0.85) * 1.7 + sky * 0.8);
  if (u_debug_morph != 0) c = mix(c, vec3(1.0, 0.1, 0.1), 0.6 * v_alpha);
  float fog = 1.0 - exp(-length(v_rel) * u_fog_density);
  c = mix(c, u_fog_color, fog);
  o_color = vec4(pow(c, vec3(1.0 / 2.2)), 1.0);
}
