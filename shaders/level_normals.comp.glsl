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

uniform int tex_size;
uniform ivec2 region_lo;    // the level region's first sample (every p read or written is in the region)
uniform ivec2 region_base;  // its texel, region_lo mod tex_size
uniform ivec4 rect;         // level samples [x0, x1) x [y0, y1)
uniform ivec2 world_lo;  // the world's first level sample
uniform ivec2 world_size;
uniform double height_offset;
uniform double meters_per_unit;

// GLSL's % is undefined for negative operands: offset from the region's corner first.
ivec2 texel(ivec2 p) { return (region_base + (p - region_lo)) % tex_size; }

double height_m(ivec2 p) {
  precise double m = height_offset + double(texelFetch(heights, texel(p), 0).r) * meters_per_unit;
  return m;
}

void main() {
  ivec2 p = rect.xy + ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= rect.z || p.y >= rect.w) return;
  // Outside the world (the edge skirt) the nearest edge sample's stencil stands in.
  ivec2 index = clamp(p - world_lo, ivec2(0), world_size - 1);
  ivec2 at = world_lo + index;
  uint pn = fd4_normal_packed(at, index, world_size);
  ivec2 q = ivec2(int(pn << 16) >> 16, int(pn) >> 16);
  imageStore(normals, texel(p), vec4(vec2(q) / 32767.0, 0.0, 0.0));
}
