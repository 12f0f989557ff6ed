// Normal map of a rect of the coarse layer (gpu/normal_pass.h): fd4_normal.glsl on the
// whole-layer height texture, one packed uint per sample.
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform usampler2D heights;  // R16UI, the whole coarse layer
layout(r32ui, binding = 1) uniform writeonly uimage2D normals;

// NormalParams (fd4_normal.glsl): n_world_size in layer texels, n_rect texels inside it.

double height_m(ivec2 p) {
  precise double m = n_height_offset + double(texelFetch(heights, p, 0).r) * n_meters_per_unit;
  return m;
}

void main() {
  ivec2 p = n_rect.xy + ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= n_rect.z || p.y >= n_rect.w) return;
  imageStore(normals, p, uvec4(fd4_normal_packed(p, p, n_world_size), 0u, 0u, 0u));
}
