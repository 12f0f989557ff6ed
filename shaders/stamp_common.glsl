// Not compiled on its own: gpu/gpu_stamper.cpp prepends this file to stamp.comp.glsl and
// shockwave.comp.glsl (after the defines). The exact integer helpers of
// protocol/stamps/stamp_profile.h and stamp_kernel.cpp, line for line, so the GPU gives the
// CPU reference's integers. GLSL's >> on int is an arithmetic shift (sign-extending), as
// C++20's; integer division is only ever done on non-negative operands here.

// Per-stamp constants (gpu/gpu_stamper.cpp, StampUniforms, std430: consecutive int32).
// Positions are relative to the texel origin of the stamp's rect, so no int64 is needed:
// d = (x - rect_x0) * 256 + d0x is the reference's gx * 256 - center_x.
layout(std430, binding = 0) readonly buffer StampParams {
  int rect_x0;  // texel of the rect's first sample (layer texture coordinates)
  int rect_y0;
  int rect_w;
  int rect_h;
  int d0x;  // rect.x0 * 256 - center_x (Q8)
  int d0y;
  int shift;  // reduction shift
  int radius_r;
  int cos_q15;
  int sin_q15;
  int intensity;
  int target;
  int blend;  // BlendMode
  int tex_w;  // texture stamps: image size
  int tex_h;
  int aux0;  // shockwave init: wave field row stride (width + 2)
  int aux1;  // shockwave init: rect origin inside the wave field's interior
  int aux2;
  int pad0;
  int pad1;
  int table[1025];
};

const int kProfileFracBits = 6;
const int kUnitQ16 = 65536;
const int kProfileEntries = 1024;

#ifdef LAYER_DETAIL
const int kLayerMin = -128;
const int kLayerMax = 127;
#else
const int kLayerMin = 0;
const int kLayerMax = 65535;
#endif

// reduce(): sign(d) * (|d| >> s), truncating toward zero.
int reduce_q8(int d, int s) { return d < 0 ? -((-d) >> s) : (d >> s); }

// isqrt32 (floor of the square root), exactly: the float square root is within a unit or
// two of it for v < 2^29, and the two loops correct it with exact integer squares. Any exact
// floor square root is the reference's; this one avoids the bit-by-bit loop, whose 15
// data-dependent iterations diverge across a SIMD lane group.
uint isqrt32(uint v) {
  uint r = uint(sqrt(float(v)));
  while (r * r > v) --r;
  while ((r + 1u) * (r + 1u) <= v) ++r;
  return r;
}

int table_lookup(int u) {
  if (u <= 0) return table[0];
  if (u >= kUnitQ16) return table[kProfileEntries];
  int i = u >> kProfileFracBits;
  int f = u & ((1 << kProfileFracBits) - 1);
  return table[i] + (((table[i + 1] - table[i]) * f) >> kProfileFracBits);
}

int round_q8(int v) { return (v + 128) >> 8; }

int saturate_layer(int v) { return clamp(v, kLayerMin, kLayerMax); }

// Stamp-relative reduced offsets of the texel at rect-local (lx, ly).
ivec2 reduced_offset(int lx, int ly) {
  return ivec2(reduce_q8(lx * 256 + d0x, shift), reduce_q8(ly * 256 + d0y, shift));
}

// radial_u_q16: u in Q16, or -1 outside the support.
int radial_u(ivec2 d) {
  uint d2 = uint(d.x * d.x + d.y * d.y);
  uint dist = isqrt32(d2);
  if (dist >= uint(radius_r)) return -1;
  return int((dist << 16) / uint(radius_r));
}
