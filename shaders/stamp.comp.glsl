// The per-sample stamp kernel on the GPU: protocol/stamps/stamp_kernel.cpp's stamp_sample,
// mirrored line by line in 32-bit integers (stamp_common.glsl is prepended). One invocation
// per sample of the stamp's rect, updated in place through image load/store (each sample
// reads only itself, so no ping-pong is needed). No atomics per changed sample: they
// serialize on llvmpipe; the host finds the changed rect while it copies the readback.
//
// Defines: KIND (StampKind value), LAYER_DETAIL (int8 layer; coarse uint16 otherwise), and
// one of PASS_STAMP, PASS_CONTACT (footprint pre-pass: first point of contact),
// PASS_WAVE_INIT (shockwave: the Gaussian pulse into the wave field).
layout(local_size_x = 8, local_size_y = 8) in;

#ifdef LAYER_DETAIL
layout(r8i, binding = 0) uniform coherent iimage2D layer_image;
int load_sample(ivec2 p) { return imageLoad(layer_image, p).r; }
void store_sample(ivec2 p, int v) { imageStore(layer_image, p, ivec4(v, 0, 0, 0)); }
#else
layout(r16ui, binding = 0) uniform coherent uimage2D layer_image;
int load_sample(ivec2 p) { return int(imageLoad(layer_image, p).r); }
void store_sample(ivec2 p, int v) { imageStore(layer_image, p, uvec4(uint(v), 0u, 0u, 0u)); }
#endif

// Footprint: the first point of contact (gathered by PASS_CONTACT, read by PASS_STAMP).
layout(std430, binding = 1) coherent buffer StampResult {
  int contact_q8;
  int has_contact;
};

#if KIND == 0
layout(binding = 0) uniform usampler2D stamp_texture;  // R16UI, read with texelFetch only

// texture_value(): bilinear with Q8 integer weights; 0..65535.
uint texture_value(int ur, int vr, int rr) {
  int den = 4 * rr;
  int nx = (ur + rr) * 2 * tex_w - 2 * rr;
  int ny = (vr + rr) * 2 * tex_h - 2 * rr;
  // floor_div with den > 0, without relying on '/' of negative operands.
  int ix = nx >= 0 ? nx / den : -((-nx + den - 1) / den);
  int iy = ny >= 0 ? ny / den : -((-ny + den - 1) / den);
  uint fx = uint(((nx - ix * den) << 8) / den);
  uint fy = uint(((ny - iy * den) << 8) / den);
  int x0 = clamp(ix, 0, tex_w - 1), x1 = clamp(ix + 1, 0, tex_w - 1);
  int y0 = clamp(iy, 0, tex_h - 1), y1 = clamp(iy + 1, 0, tex_h - 1);
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

#ifdef PASS_WAVE_INIT
layout(std430, binding = 2) writeonly buffer WaveCur { int wave_cur[]; };
layout(std430, binding = 3) writeonly buffer WavePrev { int wave_prev[]; };
#endif

int blend_value(int old, int delta) {
  if (blend == 0) return saturate_layer(old + delta);
  if (blend == 1) return saturate_layer(old - delta);
  if (blend == 2) return min(old, saturate_layer(target + delta));
  return max(old, saturate_layer(target + delta));
}

void main() {
  ivec2 l = ivec2(gl_GlobalInvocationID.xy);
  if (l.x >= rect_w || l.y >= rect_h) return;
  ivec2 d = reduced_offset(l.x, l.y);

#if defined(PASS_WAVE_INIT)
  int u = radial_u(d);
  if (u < 0) return;
  int w0 = table_lookup(u);
  int at = (l.y + aux2 + 1) * aux0 + (l.x + aux1 + 1);
  wave_cur[at] = w0;
  wave_prev[at] = w0;  // at rest
#else
  ivec2 p = ivec2(rect_x0 + l.x, rect_y0 + l.y);
  int old = load_sample(p);
#if defined(PASS_CONTACT)
  int u = radial_u(d);
  if (u < 0) return;
  atomicMax(contact_q8, old * 256 - table_lookup(u));
  atomicOr(has_contact, 1);
#else
  int nv = old;
#if KIND == 0
  // Image axes are the stamp axes rotated counter-clockwise: the offset rotated clockwise.
  int ur = (d.x * cos_q15 + d.y * sin_q15) >> 15;
  int vr = (d.y * cos_q15 - d.x * sin_q15) >> 15;
  if (ur > -radius_r && ur < radius_r && vr > -radius_r && vr < radius_r) {
    uint t = texture_value(ur, vr, radius_r);
    int u = int(t + (t >> 15));  // 65535 -> 65536: white is the full intensity
    nv = blend_value(old, round_q8(table_lookup(u)));
  }
#else
  int u = radial_u(d);
  if (u >= 0) {
#if KIND == 1 || KIND == 2
    nv = blend_value(old, round_q8(table_lookup(u)));
#elif KIND == 3
    if (has_contact != 0) {
      int sole = round_q8(contact_q8 - intensity + table_lookup(u));
      nv = min(old, saturate_layer(sole));
    }
#elif KIND == 4
    int w = table_lookup(u);  // Q14
    nv = old + (((target - old) * w + 8192) >> 14);
#endif
  }
#endif
  if (nv != old) store_sample(p, nv);
#endif
#endif
}
