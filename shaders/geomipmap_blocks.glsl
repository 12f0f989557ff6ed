// The geomipmap program's uniform block (bench/lod/geomipmap_renderer.h), mirrored by
// GeomipmapFrameBlock and checked against the linked program at creation.
layout(std140, binding = 0) uniform GeomipmapFrame {
  mat4 g_view_proj;
  ivec4 g_grid;        // patch size (vertices per side), levels, world width, world height (samples)
  vec4 g_scale;        // meters per sample, meters per unit, height offset minus the camera's z, -
  vec4 g_sun;          // render frame, unit, toward the sun; w: -
  vec4 g_height_range; // material range, meters above the height offset (x, y); -
};
