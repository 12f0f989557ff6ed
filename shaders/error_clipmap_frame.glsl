// The error-driven clipmap's own per-frame block (after geomipmap_blocks.glsl's GeomipmapFrame),
// mirrored by ErrorClipmapFrameBlock (client/render/error_clipmap_renderer.h).
layout(std140, binding = 4) uniform ErrorClipmapFrame {
  ivec2 e_anchor;   // the mip-0 sample (world-relative) v_sample counts from
  float e_skirt_z;  // camera-relative height of the skirt's foot
  int e_level_count;
  // Per level: its layer of the level textures and the texel of its sample (0, 0) there (a
  // level held whole shares a layer with others; a torus has its own, offset 0). Level sample q
  // lives at texel (q + offset) mod P.
  ivec4 e_levels[24];
};
