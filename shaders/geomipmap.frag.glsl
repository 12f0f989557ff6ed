// Geomipmap shading: the triangle's own normal (from screen-space derivatives) shaded by
// patch_shading.glsl.
in vec3 v_rel;
in float v_height;

out vec4 o_color;

void main() {
  vec3 n = normalize(cross(dFdx(v_rel), dFdy(v_rel)));
  if (n.z < 0.0) n = -n;
  o_color = shade_patch(n, v_height);
}
