// What the level passes that follow a stamp read (gpu/level_fill.h): the stamp's mip-0 rect,
// written once per stamp, and every level's place, written when a level moves. Each level's
// rect is computed here from them, as ErrorClipmapRenderer::invalidate computes it, and one
// dispatch covers every level: invocation i takes the i-th sample of the levels' rects laid
// end to end, so a stamp costs one small block and two dispatches however many levels it
// reaches.
layout(std140, binding = 7) uniform LevelEvent {
  ivec4 e_rect0;   // mip-0 samples that changed, world-relative [x0, y0, x1, y1)
  ivec4 e_tiles;   // the page table's first tile (x, y), tiles per row, -
  ivec4 e_world;   // the world's first global sample (x, y) and its size in samples (w, h)
  ivec4 e_levels;  // the level count, -, -, -
};

struct LevelSlot {
  ivec4 region;    // the level's samples held [x0, y0, x1, y1) (world-relative level grid)
  ivec4 drawable;  // where its normals are defined
  ivec4 texel;     // its texel offset (x, y), layer, tex_size
  ivec4 change;    // update the change layer (0/1), below which level sample (x, y), stride 2^l
  vec4 scale;      // meters per height unit
};
layout(std430, binding = 6) readonly buffer LevelSlots { LevelSlot l_slots[]; };

ivec4 intersect_rect(ivec4 a, ivec4 b) { return ivec4(max(a.xy, b.xy), min(a.zw, b.zw)); }

// Level l's samples whose mip-0 position lies in e_rect0, and past the far edges those that
// repeat an edge sample in it, inside the level's region.
ivec4 level_rect(int l) {
  int s = l_slots[l].change.w;
  ivec4 r = ivec4((e_rect0 + (s - 1)) / s);
  if (e_rect0.z == e_world.z) r.z = 0x3fffffff;
  if (e_rect0.w == e_world.w) r.w = 0x3fffffff;
  return intersect_rect(r, l_slots[l].region);
}

// Where level l's normals change: its rect grown by the stencil's 4 samples, where defined.
ivec4 level_normals_rect(int l) {
  return intersect_rect(level_rect(l) + ivec4(-4, -4, 4, 4), l_slots[l].drawable);
}

// This invocation's place in the levels' rects laid end to end (64 a group, groups in rows of
// gl_NumWorkGroups.x): its level and sample; false past the last.
bool level_sample(bool normals, out int level, out ivec2 q) {
  uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 64u + gl_LocalInvocationIndex;
  for (int l = 0; l < e_levels.x; ++l) {
    ivec4 r = normals ? level_normals_rect(l) : level_rect(l);
    int w = max(r.z - r.x, 0), h = max(r.w - r.y, 0);
    uint n = uint(w) * uint(h);
    if (i < n) {
      level = l;
      q = r.xy + ivec2(int(i % uint(w)), int(i / uint(w)));
      return true;
    }
    i -= n;
  }
  return false;
}
