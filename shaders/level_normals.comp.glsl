// Normal map of a rect of one clipmap level (gpu/normal_pass.h, LevelNormalPass):
// fd4_normal.glsl on the level's toroidal height texture (level sample p at texel
// p mod tex_size), written to its toroidal RG16_SNORM normal texture (so the renderer samples
// it with hardware filtering). The stored snorm16 values are exactly the packed reference's:
// q / 32767 converts back to q under any rounding (it is never a tie). Level samples are the
// world's at the level's spacing, so the finest level's normals are exactly the world normal
// map's.
#ifdef FROM_EVENT
// After a stamp, every level at once (level_event.glsl, included first): the level array
// textures, and each level's NormalParams from an array.
layout(local_size_x = 64) in;
layout(binding = 0) uniform usampler2DArray heights;  // R16UI, tex_size^2 x layers
layout(rg16_snorm, binding = 1) uniform writeonly image2DArray normals;
struct LevelNormal {  // NormalParams' members, in its order (gpu/normal_pass.h, NormalBlock)
  ivec4 rect;
  ivec2 world_lo, world_size, region_lo, region_base;
  int tex_size, pad0;
  double height_offset, meters_per_unit, spacing;
};
layout(std430, binding = 9) readonly buffer LevelNormals { LevelNormal n_levels[]; };
int n_layer;
#else
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0) uniform usampler2D heights;  // R16UI, tex_size^2
layout(rg16_snorm, binding = 1) uniform writeonly image2D normals;
#endif

// NormalParams (fd4_normal.glsl): n_rect in level samples; the level region (every p read or
// written is in it) starts at n_region_lo, held at texel n_region_base of the toroidal texture.

// GLSL's % is undefined for negative operands: offset from the region's corner first.
ivec2 texel(ivec2 p) { return (n_region_base + (p - n_region_lo)) % n_tex_size; }

#ifdef FROM_EVENT
uint height_at(ivec2 p) { return texelFetch(heights, ivec3(texel(p), n_layer), 0).r; }
#else
uint height_at(ivec2 p) { return texelFetch(heights, texel(p), 0).r; }
#endif

double height_m(ivec2 p) {
  precise double m = n_height_offset + double(height_at(p)) * n_meters_per_unit;
  return m;
}

void main() {
#ifdef FROM_EVENT
  int l;
  ivec2 p0;
  if (!level_sample(true, l, p0)) return;
  LevelNormal n = n_levels[l];
  n_world_lo = n.world_lo, n_world_size = n.world_size, n_region_lo = n.region_lo;
  n_region_base = n.region_base, n_tex_size = n.tex_size;
  n_height_offset = n.height_offset, n_meters_per_unit = n.meters_per_unit, n_spacing = n.spacing;
  n_layer = l_slots[l].texel.z;
  // level_sample() counts in the level's own samples; the pass works in its layer's texels.
  ivec2 p = p0 + l_slots[l].texel.xy;
#else
  ivec2 p = n_rect.xy + ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= n_rect.z || p.y >= n_rect.w) return;
#endif
  // Outside the world (the edge skirt) the nearest edge sample's stencil stands in.
  ivec2 index = clamp(p - n_world_lo, ivec2(0), n_world_size - 1);
  ivec2 at = n_world_lo + index;
  uint pn = fd4_normal_packed(at, index, n_world_size);
  ivec2 q = ivec2(int(pn << 16) >> 16, int(pn) >> 16);
#ifdef FROM_EVENT
  imageStore(normals, ivec3(texel(p), n_layer), vec4(vec2(q) / 32767.0, 0.0, 0.0));
#else
  imageStore(normals, texel(p), vec4(vec2(q) / 32767.0, 0.0, 0.0));
#endif
}
