// Terrain shading, shared by the clipmap and the error-driven clipmap (after
// terrain_shading_block.glsl): the level's normal perturbed by the detail layer's gradient near
// the camera; materials splatted by height, slope and curvature (sand, grass, dry grass, rock,
// snow, sea floor), each modulated by its tiling detail texture at two scales turned against
// each other and mixed by a slow variation, so no repeat lines up at grazing angles; exposed
// earth, banded by height, where the terrain was dug (and loose earth where it was heaped),
// from the change layer; a sun with a shadow map (4 filtered taps, faded out at the map's edge)
// and a sky hemisphere ambient; distance fog into the sky colour; flat-shaded earth on the
// skirt. Alpha is 1 on terrain so a background pixel (alpha 0 after the clear) is detectable
// in tests.
layout(binding = 4) uniform sampler2D u_detail_gradient;  // RG16F, meters per meter
layout(binding = 6) uniform sampler2DArray u_materials;   // RGBA8, layers: rock, grass, sand, snow, earth
layout(binding = 7) uniform sampler2DShadow u_shadow;     // the sun's, reversed depth

// What the renderer knows of a fragment (built positionally: TerrainPoint(rel, sample_pos, ...)).
struct TerrainPoint {
  vec3 rel;         // camera-relative position (render frame: x east, y north, z up)
  vec2 sample_pos;  // mip-0 samples from the anchor (world grid: y along +gy)
  float height_m;   // meters above the height offset's zero
  vec2 nxy;         // the level's filtered normal (nx, ny), world grid
  float curv;       // the height's Laplacian at the level's spacing, 1/m (> 0: concave)
  float change;     // meters against the initial terrain (read where t_change_on)
  float skirt;      // 0 on terrain, toward 1 down the skirt's wall
  float morph;      // geomorph blend toward the coarser level (the debug tint)
};

const float kRock = 0.0, kGrass = 1.0, kSand = 2.0, kSnow = 3.0, kEarth = 4.0;

// A material's detail (mean about 1): two scales turned against each other, mixed by `macro`.
vec3 detail_of(float layer, vec2 uv_a, vec2 uv_b, float macro) {
  vec3 a = texture(u_materials, vec3(uv_a, layer)).rgb, b = texture(u_materials, vec3(uv_b, layer)).rgb;
  return 2.0 * mix(a, b, macro);
}

// Fraction of the sun that reaches a point (1 outside the shadow map's square).
float sunlight(vec3 rel, vec3 n) {
  // Offset along the normal by about a texel against acne on slopes facing away.
  vec4 c = t_light_view_proj * vec4(rel + n * 0.6, 1.0);
  vec2 uv = c.xy * 0.5 + 0.5;
  float edge = max(abs(c.x), abs(c.y));
  if (edge >= 1.0) return 1.0;
  float d = c.z + 0.0002;
  vec2 t = vec2(t_shadow_texel);
  float lit = 0.25 * (texture(u_shadow, vec3(uv + vec2(-0.5, -0.5) * t, d)) + texture(u_shadow, vec3(uv + vec2(0.5, -0.5) * t, d)) +
                      texture(u_shadow, vec3(uv + vec2(-0.5, 0.5) * t, d)) + texture(u_shadow, vec3(uv + vec2(0.5, 0.5) * t, d)));
  return mix(lit, 1.0, smoothstep(0.85, 1.0, edge));
}

// Call from uniform control flow: it takes screen-space derivatives.
vec4 shade_terrain(TerrainPoint p) {
  // Derivatives first: the skirt's flat normal, the detail footprint.
  vec3 face = cross(dFdx(p.rel), dFdy(p.rel));
  vec2 dc = p.sample_pos * float(t_detail_factor) - vec2(t_detail_rel_origin);
  float footprint = max(length(dFdx(dc)), length(dFdy(dc)));
  vec3 n;
  bool wall = p.skirt > 1e-3;
  if (wall) {
    n = normalize(face);
    if (dot(n, p.rel) > 0.0) n = -n;
  } else {
    // The terrain's gradient, plus the detail layer's where a pixel resolves it.
    vec2 g = -p.nxy / sqrt(max(1.0 - dot(p.nxy, p.nxy), 1e-6));
    if (t_detail_on != 0) {
      // Gradients exist one sample inside the region and filtering reads one more: fade in
      // from two samples in, so nothing outside the region (stale wrap-around) contributes.
      float border = min(min(dc.x, dc.y), min(float(t_detail_size) - dc.x, float(t_detail_size) - dc.y)) - 2.0;
      float w = clamp(border / 16.0, 0.0, 1.0) * clamp(2.0 - footprint, 0.0, 1.0);
      if (w > 0.0) g += w * texture(u_detail_gradient, (vec2(t_detail_base) + dc + 0.5) / float(t_detail_size)).rg;
    }
    // World y runs south; the render frame's north.
    n = normalize(vec3(-g.x, g.y, 1.0));
  }
  float slope = 1.0 - n.z;  // 0 flat, 1 vertical
  float land = max(t_height_range.y - t_sea_level, 1e-3);
  float t = clamp((p.height_m - t_sea_level) / land, 0.0, 1.0);
  // Curvature, scaled so a crater floor or a gully reads about +1, a rim or ridge about -1.
  float k = clamp(p.curv * 25.0, -1.0, 1.0);
  const vec3 sand = vec3(0.50, 0.44, 0.30), grass = vec3(0.13, 0.21, 0.07), dry = vec3(0.27, 0.25, 0.14);
  const vec3 rock = vec3(0.24, 0.22, 0.21), snow = vec3(0.85, 0.88, 0.93);
  const vec3 shallow = vec3(0.10, 0.28, 0.30), deep = vec3(0.02, 0.07, 0.16);
  const vec3 earth = vec3(0.20, 0.14, 0.09), earth_deep = vec3(0.11, 0.08, 0.06);
  vec2 p_m = p.sample_pos * t_meters_per_sample;  // meters from the anchor
  vec2 uv_a = p_m / 5.3 + t_tex_phase.xy;
  const float cb = cos(0.6458), sb = sin(0.6458);
  vec2 uv_b = vec2(cb * p_m.x - sb * p_m.y, sb * p_m.x + cb * p_m.y) / 37.0 + t_tex_phase.zw;
  float macro = 0.5;
  if (t_materials_on != 0) macro = smoothstep(0.35, 0.65, texture(u_materials, vec3(p_m / 431.0 + t_macro_phase, kRock)).g);
  vec3 one = vec3(1.0);
  bool textured = t_materials_on != 0;
  vec3 tex_sand = textured ? detail_of(kSand, uv_a, uv_b, macro) : one;
  vec3 tex_grass = textured ? detail_of(kGrass, uv_a, uv_b, macro) : one;
  vec3 tex_rock = textured ? detail_of(kRock, uv_a, uv_b, macro) : one;
  vec3 tex_snow = textured ? detail_of(kSnow, uv_a, uv_b, macro) : one;
  // Height bands, then slope (steeper on convex ground) and snow where it can lie.
  float rockiness = smoothstep(0.18, 0.40, slope + (textured ? -0.08 * k : 0.0));
  vec3 albedo = mix(sand * tex_sand, grass * tex_grass, smoothstep(0.01, 0.05, t));
  albedo = mix(albedo, dry * tex_grass, smoothstep(0.25, 0.50, t - (textured ? 0.06 * k : 0.0)));
  albedo = mix(albedo, rock * tex_rock, rockiness);
  albedo = mix(albedo, snow * tex_snow, smoothstep(0.62, 0.75, t) * (1.0 - smoothstep(0.30, 0.55, slope)));
  if (p.height_m < t_sea_level) {
    float depth = (t_sea_level - p.height_m) / max(t_sea_level - t_height_range.x, 1e-3);
    albedo = mix(shallow, deep, smoothstep(0.0, 0.35, depth)) * mix(one, tex_sand, 0.5);
  }
  // Dug ground shows earth, in bands by height on the walls; heaped ground loose, paler earth.
  if (t_change_on != 0 && !wall) {
    float dug = smoothstep(0.03, 0.5, -p.change), heaped = smoothstep(0.03, 0.4, p.change);
    if (dug + heaped > 0.0) {
      vec3 tex_earth = textured ? detail_of(kEarth, uv_a * 2.0, uv_b * 2.0, macro) : one;
      float band = fract(p.height_m / 0.9);
      vec3 strata = mix(vec3(0.30, 0.21, 0.13), vec3(0.22, 0.16, 0.11), smoothstep(0.35, 0.65, band));
      strata = mix(strata, vec3(0.38, 0.30, 0.20), smoothstep(0.85, 0.95, band) * smoothstep(0.25, 0.6, slope));
      vec3 dug_colour = mix(strata, strata * 0.7, smoothstep(0.5, 4.0, -p.change)) * tex_earth;
      vec3 heap_colour = vec3(0.42, 0.33, 0.23) * tex_earth;
      albedo = mix(albedo, heap_colour, 0.85 * heaped);
      albedo = mix(albedo, dug_colour, dug);
    }
  }
  if (wall) albedo = mix(earth, earth_deep, p.skirt);
  float sun = max(dot(n, t_sun_dir), 0.0);
  if (t_shadows_on != 0 && sun > 0.0 && !wall) sun *= sunlight(p.rel, n);
  vec3 sky = mix(vec3(0.18, 0.16, 0.14), vec3(0.42, 0.52, 0.70), 0.5 + 0.5 * n.z);
  vec3 c = albedo * (sun * vec3(1.10, 1.00, 0.85) * 1.7 + sky * 0.8);
  if (t_debug_morph != 0) c = mix(c, vec3(1.0, 0.1, 0.1), 0.6 * p.morph);
  float fog = 1.0 - exp(-length(p.rel) * t_fog_density);
  c = mix(c, t_fog_color, fog);
  return vec4(pow(c, vec3(1.0 / 2.2)), 1.0);
}
