// Not compiled on its own: gpu/gpu_stamper.cpp prepends this file to stamp.comp.glsl and
// stamp.vert.glsl (after the defines). The exact integer helpers of
// protocol/stamps/stamp_profile.h and the per-sample kernel of stamp_kernel.cpp, so the GPU
// gives the CPU reference's integers. GLSL's >> on int is an arithmetic shift
// (sign-extending), as C++20's; integer division is only ever done on non-negative operands.
//
// Written for llvmpipe as much as for a GPU, where each SIMD lane group runs every branch
// under a mask: the per-sample code has no data-dependent branches or loops (selects
// instead), and every per-stamp constant is read once, in load_stamp() at the top of main,
// before anything diverges (llvmpipe turns a uniform-block read under a per-lane mask into a
// per-lane gather).
//
// Defines, generated from the kinds table (protocol/stamps/stamp_kinds.h): KIND (the program's
// StampKind value), KIND_<NAME> for every kind, KIND_NEEDS_CONTACT (0 or 1); and LAYER_DETAIL
// (int8 layer; coarse uint16 otherwise).

// Per-stamp constants (gpu/gpu_stamper.cpp, StampUniforms): consecutive int32 in five ivec4
// and the profile table packed four entries to an ivec4, so std140 adds no padding and the
// bytes are those of the host struct.
layout(std140, binding = 0) uniform StampParams {
  ivec4 p_rect;    // texel of the rect's first sample (layer texture coordinates), width, height
  ivec4 p_reduce;  // d0x, d0y = rect.x0 * 256 - center (Q8), reduction shift, reduced radius
  ivec4 p_shade;   // cos_q15, sin_q15, intensity, target
  ivec4 p_misc;    // blend, texture width, texture height, the vertex pass's runs per row
  ivec4 p_wave;    // shockwave init: wave field row stride (width + 2), rect origin in its interior, -
  ivec4 table4[257];  // profile table entry i = table4[i >> 2][i & 3], i = 0..1024
};

const int kProfileFracBits = 6;
const int kUnitQ16 = 65536;
const int kProfileEntries = 1024;
const int kNoContact = -2147483647 - 1;  // INT_MIN: no sample under the foot

#ifdef LAYER_DETAIL
const int kLayerMin = -128;
const int kLayerMax = 127;
#else
const int kLayerMin = 0;
const int kLayerMax = 65535;
#endif

struct Stamp {
  ivec2 origin;  // texel of rect-local (0, 0)
  ivec2 size;    // rect width, height
  ivec2 d0;      // Q8 offset of rect-local (0, 0) from the center
  int shift;
  int radius_r;
  float inv_radius;  // 1 / radius_r, only a first guess for div_q16
  int cos_q15;
  int sin_q15;
  int intensity;
  int target;
  int blend;
  ivec2 tex_size;
};

Stamp load_stamp() {
  Stamp s;
  s.origin = p_rect.xy;
  s.size = p_rect.zw;
  s.d0 = p_reduce.xy;
  s.shift = p_reduce.z;
  s.radius_r = p_reduce.w;
  s.inv_radius = 1.0 / float(p_reduce.w);
  s.cos_q15 = p_shade.x;
  s.sin_q15 = p_shade.y;
  s.intensity = p_shade.z;
  s.target = p_shade.w;
  s.blend = p_misc.x;
  s.tex_size = p_misc.yz;
  return s;
}

// reduce(): sign(d) * (|d| >> s), truncating toward zero.
int reduce_q8(int d, int s) { return d < 0 ? -((-d) >> s) : (d >> s); }

// isqrt32 (floor of the square root) for 0 <= v < 2^29, exactly: the float square root is
// within 0.02 of the true one there (float(v) and sqrt are each a few ulps off, and
// sqrt(v) < 2^14.5), so its truncation is the floor or one off either way; one exact integer
// step each way corrects it (docs/stamps.md, bit budget 3).
int isqrt_small(int v) {
  int r = int(sqrt(float(v)));
  r = r * r > v ? r - 1 : r;
  r = (r + 1) * (r + 1) <= v ? r + 1 : r;
  return r;
}

// floor((dist << 16) / r) for 0 <= dist < r < 2^14, exactly: the quotient is below 2^16 and
// the float estimate (n < 2^30 and 1/r each a few ulps off) within 1/32 of it, so one exact
// step each way corrects the truncation. Integer division would be eight scalar divides per
// SIMD lane group on llvmpipe. Lanes with dist >= r get some value; callers discard it.
int div_q16(int dist, int r, float inv_r) {
  uint n = uint(dist) << 16;
  uint q = uint(float(n) * inv_r);
  q = q * uint(r) > n ? q - 1u : q;
  q = (q + 1u) * uint(r) <= n ? q + 1u : q;
  return int(q);
}

int table_at(int i) { return table4[i >> 2][i & 3]; }

// table_lookup without branches: u clamped to [0, 65536]; at u = 65536 the last segment with
// f = 64 gives T[1024] exactly (((T[1024] - T[1023]) * 64) >> 6 is exact), as the
// reference's u >= 65536 case; u <= 0 gives T[0].
int table_lookup(int u) {
  int uc = clamp(u, 0, kUnitQ16);
  int i = min(uc >> kProfileFracBits, kProfileEntries - 1);
  int f = uc - (i << kProfileFracBits);
  int t0 = table_at(i);
  int t1 = table_at(i + 1);
  return t0 + (((t1 - t0) * f) >> kProfileFracBits);
}

int round_q8(int v) { return (v + 128) >> 8; }

int saturate_layer(int v) { return clamp(v, kLayerMin, kLayerMax); }

// Stamp-relative reduced offsets of the texel at rect-local l.
ivec2 reduced_offset(const Stamp s, ivec2 l) {
  return ivec2(reduce_q8(l.x * 256 + s.d0.x, s.shift), reduce_q8(l.y * 256 + s.d0.y, s.shift));
}

// radial_u_q16: u in Q16, or -1 outside the support. Lanes beyond the rect (partial lane
// groups) compute garbage that is never stored.
int radial_u(const Stamp s, ivec2 l) {
  ivec2 d = reduced_offset(s, l);
  int dist = isqrt_small(d.x * d.x + d.y * d.y);
  int u = div_q16(dist, s.radius_r, s.inv_radius);
  return dist < s.radius_r ? u : -1;
}

int blend_value(const Stamp s, int old, int delta) {
  int add = saturate_layer(old + delta);
  int sub = saturate_layer(old - delta);
  int to_target = saturate_layer(s.target + delta);
  int towards = s.blend == 2 ? min(old, to_target) : max(old, to_target);
  return s.blend == 0 ? add : (s.blend == 1 ? sub : towards);
}

#if KIND == KIND_TEXTURE
layout(binding = 0) uniform usampler2D stamp_texture;  // R16UI, read with texelFetch only

// texture_value(): bilinear with Q8 integer weights; 0..65535. ur, vr in (-rr, rr), so
// nx >= -2rr > -den and floor(nx / den) = (nx + den) / den - 1 divides non-negative numbers.
uint texture_value(const Stamp s, int ur, int vr, int rr) {
  int den = 4 * rr;
  int nx = (ur + rr) * 2 * s.tex_size.x - 2 * rr;
  int ny = (vr + rr) * 2 * s.tex_size.y - 2 * rr;
  int ix = (nx + den) / den - 1;
  int iy = (ny + den) / den - 1;
  uint fx = uint(((nx - ix * den) << 8) / den);
  uint fy = uint(((ny - iy * den) << 8) / den);
  int x0 = clamp(ix, 0, s.tex_size.x - 1), x1 = clamp(ix + 1, 0, s.tex_size.x - 1);
  int y0 = clamp(iy, 0, s.tex_size.y - 1), y1 = clamp(iy + 1, 0, s.tex_size.y - 1);
  uint a = texelFetch(stamp_texture, ivec2(x0, y0), 0).r;
  uint b = texelFetch(stamp_texture, ivec2(x1, y0), 0).r;
  uint c = texelFetch(stamp_texture, ivec2(x0, y1), 0).r;
  uint d = texelFetch(stamp_texture, ivec2(x1, y1), 0).r;
  uint top = a * (256u - fx) + b * fx;
  uint bot = c * (256u - fx) + d * fx;
  uint v = top * (256u - fy) + bot * fy;
  return (v + 32768u) >> 16;
}
#endif

// stamp_sample(): the new value of the sample at rect-local l holding `old` (`old` itself
// outside the support). `contact` is the footprint's first point of contact (kNoContact:
// none); other kinds ignore it.
int stamp_sample(const Stamp s, ivec2 l, int old, int contact) {
#if KIND == KIND_TEXTURE
  // Image axes are the stamp axes rotated counter-clockwise: the offset rotated clockwise.
  ivec2 d = reduced_offset(s, l);
  int rr = s.radius_r;
  int ur = (d.x * s.cos_q15 + d.y * s.sin_q15) >> 15;
  int vr = (d.y * s.cos_q15 - d.x * s.sin_q15) >> 15;
  bool in_support = ur > -rr && ur < rr && vr > -rr && vr < rr;
  uint t = texture_value(s, clamp(ur, 1 - rr, rr - 1), clamp(vr, 1 - rr, rr - 1), rr);
  int u = int(t + (t >> 15));  // 65535 -> 65536: white is the full intensity
  return in_support ? blend_value(s, old, round_q8(table_lookup(u))) : old;
#else
  int u = radial_u(s, l);
  int w = table_lookup(u);
#if KIND == KIND_GAUSSIAN || KIND == KIND_CRATER
  int nv = blend_value(s, old, round_q8(w));
#elif KIND == KIND_FOOTPRINT
  int nv = contact != kNoContact ? min(old, saturate_layer(round_q8(contact - s.intensity + w))) : old;
#elif KIND == KIND_FLATTEN
  int nv = old + (((s.target - old) * w + 8192) >> 14);  // w: Q14 weight
#else
  int nv = old;
#endif
  return u >= 0 ? nv : old;
#endif
}

// Footprint pre-pass: old * 256 - sole(u) under the foot, kNoContact elsewhere. That value
// is above kNoContact for every real sample (old * 256 >= -32768, sole < 2^26), so the
// maximum over the foot is the contact and kNoContact means no sample lies under it.
int contact_value(const Stamp s, ivec2 l, int old) {
  int u = radial_u(s, l);
  return u >= 0 ? old * 256 - table_lookup(u) : kNoContact;
}
