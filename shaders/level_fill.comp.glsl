// Fills the levels' samples after a stamp from the GPU tile cache (gpu/level_fill.h): level
// sample q reads mip-0 sample clamp(q * stride, 0, size - 1) of the world (decimation: every mip
// holds every 2^l-th mip-0 sample; past the far edges, the edge sample), found through the page
// table, and is stored at texel (q + offset) mod tex_size of its level's layer. Where asked, the
// change layer (meters against the initial terrain) moves by the height difference, in whole
// height units, so it stays what the CPU computes from the heights. level_event.glsl comes
// first.
layout(local_size_x = 64) in;

layout(binding = 0) uniform usampler2DArray pages;  // R16UI tile pages, 256x256
layout(r16ui, binding = 0) uniform uimage2DArray heights;
layout(r16f, binding = 1) uniform image2DArray change;

layout(std430, binding = 5) readonly buffer FillPages { int f_pages[]; };

void main() {
  int l;
  ivec2 q;
  if (!level_sample(false, l, q)) return;
  LevelSlot slot = l_slots[l];
  ivec2 p = e_world.xy + clamp(q * slot.change.w, ivec2(0), e_world.zw - 1);
  // >> and & on two's complement: floor division and modulo by 256, negatives included.
  ivec2 t = (p >> 8) - e_tiles.xy;
  int page = f_pages[t.y * e_tiles.z + t.x];
  uint h = texelFetch(pages, ivec3(p & 255, page), 0).r;
  ivec3 at = ivec3((q + slot.texel.xy) % slot.texel.w, slot.texel.z);
  if (slot.change.x != 0 && q.x < slot.change.y && q.y < slot.change.z) {
    int before = int(imageLoad(heights, at).r);
    float units = round(imageLoad(change, at).r / slot.scale.x) + float(int(h) - before);
    imageStore(change, at, vec4(units * slot.scale.x, 0.0, 0.0, 0.0));
  }
  imageStore(heights, at, uvec4(h, 0u, 0u, 0u));
}
