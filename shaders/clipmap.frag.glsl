// Terrain shading: height/slope materials (sand, grass, dry grass, rock, snow), a sun with a
// sky hemisphere ambient, and distance fog into the sky colour. Alpha is 1 on terrain so a
// background pixel (alpha 0 after the clear) is detectable in tests.
in vec3 v_rel;
in vec3 v_normal;
in float v_height;
in float v_alpha;

uniform vec3 u_sun_dir;       // render frame, unit, toward the sun
uniform vec2 u_height_range;  // material range, meters above the height offset
uniform float u_sea_level;    // meters above the height offset; below it is sea floor
uniform vec3 u_fog_color;     // linear
uniform float u_fog_density;  // per meter
uniform int u_debug_morph;    // tint by geomorph blend

out vec4 o_color;

void main() {
  vec3 n = normalize(v_normal);
  float slope = 1.0 - n.z;  // 0 flat, 1 vertical
  float land = max(u_height_range.y - u_sea_level, 1e-3);
  float t = clamp((v_height - u_sea_level) / land, 0.0, 1.0);
  const vec3 sand = vec3(0.50, 0.44, 0.30), grass = vec3(0.13, 0.21, 0.07), dry = vec3(0.27, 0.25, 0.14);
  const vec3 rock = vec3(0.24, 0.22, 0.21), snow = vec3(0.85, 0.88, 0.93);
  const vec3 shallow = vec3(0.10, 0.28, 0.30), deep = vec3(0.02, 0.07, 0.16);
  vec3 albedo = mix(sand, grass, smoothstep(0.01, 0.05, t));
  albedo = mix(albedo, dry, smoothstep(0.25, 0.50, t));
  albedo = mix(albedo, rock, smoothstep(0.18, 0.40, slope));
  albedo = mix(albedo, snow, smoothstep(0.62, 0.75, t) * (1.0 - smoothstep(0.30, 0.55, slope)));
  if (v_height < u_sea_level) {
    float depth = (u_sea_level - v_height) / max(u_sea_level - u_height_range.x, 1e-3);
    albedo = mix(shallow, deep, smoothstep(0.0, 0.35, depth));
  }
  float sun = max(dot(n, u_sun_dir), 0.0);
  vec3 sky = mix(vec3(0.18, 0.16, 0.14), vec3(0.42, 0.52, 0.70), 0.5 + 0.5 * n.z);
  vec3 c = albedo * (sun * vec3(1.10, 1.00, 0.85) * 1.7 + sky * 0.8);
  if (u_debug_morph != 0) c = mix(c, vec3(1.0, 0.1, 0.1), 0.6 * v_alpha);
  float fog = 1.0 - exp(-length(v_rel) * u_fog_density);
  c = mix(c, u_fog_color, fog);
  o_color = vec4(pow(c, vec3(1.0 / 2.2)), 1.0);
}
