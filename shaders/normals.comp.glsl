// Normal map of a rect of the coarse layer (gpu/normal_pass.h): fd4_normal.glsl on the
// whole-layer height texture, one packed uint per sample.
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform usampler2D heights;  // R16UI, the whole coarse layer
layout(r32ui, binding = 1) uniform writeonly uimage2D normals;

uniform ivec2 world_size;  // layer texels
uniform ivec4 rect;        // texels [x0, x1) x [y0, y1), inside the world
uniform double height_offset;
uniform double meters_per_unit;

double height_m(ivec2 p) {
  precise double m = height_offset + double(texelFetch(heights, p, 0).r) * meters_per_unit;
  return m;
}

void main() {
  ivec2 p = rect.xy + ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= rect.z || p.y >= rect.w) return;
  imageStore(normals, p, uvec4(fd4_normal_packed(p, p, world_size), 0u, 0u, 0u));
}
