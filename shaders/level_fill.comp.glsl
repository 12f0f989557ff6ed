// Fills level samples of a clipmap level from the GPU tile cache (gpu/level_fill.h): level
// sample q reads mip-0 sample clamp(q * stride, 0, size - 1) of the world (decimation: every mip
// holds every 2^l-th mip-0 sample; past the far edges, the edge sample), found through the page
// table, and is stored at texel (q + offset) mod tex_size of its layer. Where asked, the change
// layer (meters against the initial terrain) moves by the height difference, in whole height
// units, so it stays what the CPU computes from the heights.
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform usampler2DArray pages;  // R16UI tile pages, 256x256
layout(r16ui, binding = 0) uniform uimage2DArray heights;
layout(r16f, binding = 1) uniform image2DArray change;

layout(std430, binding = 5) readonly buffer FillPages { int f_pages[]; };

layout(std140, binding = 6) uniform LevelFillParams {
  ivec4 f_rect;    // level samples [x0, y0, x1, y1) to fill (world-relative level grid)
  ivec4 f_world;   // the world's first global sample (x, y) and its size (w, h)
  ivec4 f_tiles;   // the page table's first tile (x, y), tiles per row, stride 2^l
  ivec4 f_texel;   // the level's texel offset (x, y), its layer, tex_size
  ivec4 f_change;  // update the change layer (0/1), and below which level sample (x, y) it may
  vec4 f_scale;    // meters per height unit
};

void main() {
  ivec2 q = f_rect.xy + ivec2(gl_GlobalInvocationID.xy);
  if (q.x >= f_rect.z || q.y >= f_rect.w) return;
  ivec2 p = f_world.xy + clamp(q * f_tiles.w, ivec2(0), f_world.zw - 1);
  // >> and & on two's complement: floor division and modulo by 256, negatives included.
  ivec2 t = (p >> 8) - f_tiles.xy;
  int page = f_pages[t.y * f_tiles.z + t.x];
  uint h = texelFetch(pages, ivec3(p & 255, page), 0).r;
  ivec3 at = ivec3((q + f_texel.xy) % f_texel.w, f_texel.z);
  if (f_change.x != 0 && q.x < f_change.y && q.y < f_change.z) {
    int before = int(imageLoad(heights, at).r);
    float units = round(imageLoad(change, at).r / f_scale.x) + float(int(h) - before);
    imageStore(change, at, vec4(units * f_scale.x, 0.0, 0.0, 0.0));
  }
  imageStore(heights, at, uvec4(h, 0u, 0u, 0u));
}
