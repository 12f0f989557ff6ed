// Normal map of a rect of one clipmap level (gpu/normal_pass.h, LevelNormalPass):
// fd4_normal.glsl on the level's toroidal height texture (level sample p at texel
// p mod tex_size), written to its toroidal RG16_SNORM normal texture (so the renderer samples
// it with hardware filtering). The stored snorm16 values are exactly the packed reference's:
// q / 32767 converts back to q under any rounding (it is never a tie). Level samples are the
// world's at the level's spacing, so the finest level's normals are exactly the world normal
// map's.
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform usampler2D heights;  // R16UI, tex_size^2
layout(rg16_snorm, binding = 1) uniform writeonly image2D normals;

// NormalParams (fd4_normal.glsl): n_rect in level samples; the level region (every p read or
// written is in it) starts at n_region_lo, held at texel n_region_base of the toroidal texture.

// GLSL's % is undefined for negative operands: offset from the region's corner first.
ivec2 texel(ivec2 p) { return (n_region_base + (p - n_region_lo)) % n_tex_size; }

double height_m(ivec2 p) {
  precise double m = n_height_offset + double(texelFetch(heights, texel(p), 0).r) * n_meters_per_unit;
  return m;
}

void main() {
  ivec2 p = n_rect.xy + ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= n_rect.z || p.y >= n_rect.w) return;
  // Outside the world (the edge skirt) the nearest edge sample's stencil stands in.
  ivec2 index = clamp(p - n_world_lo, ivec2(0), n_world_size - 1);
  ivec2 at = n_world_lo + index;
  uint pn = fd4_normal_packed(at, index, n_world_size);
  ivec2 q = ivec2(int(pn << 16) >> 16, int(pn) >> 16);
  imageStore(normals, texel(p), vec4(vec2(q) / 32767.0, 0.0, 0.0));
}
