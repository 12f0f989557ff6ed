// Shockwave stamps on the GPU: protocol/stamps/shockwave.cpp's wave_step and final
// application, mirrored exactly. The wave field (int32, Q8 layer units, with a one-cell
// border of zeros) lives in two storage buffers that swap roles every step (ping-pong: a
// step reads its neighbours' current values, so it cannot run in place). Products are
// int64 as in the reference (GL_ARB_gpu_shader_int64; the host checks for it).
//
// Defines: PASS_STEP (one leapfrog step over the active rect) or PASS_APPLY (terrain becomes
// saturate(old + round(w)) over the box, run once per tile page the box covers, with that
// page bound as the image), LAYER_DETAIL for the int8 layer.
#extension GL_ARB_gpu_shader_int64 : require
layout(local_size_x = 8, local_size_y = 8) in;

// The pass's parameters (gpu/gpu_stamper.cpp, WaveBlock; std140, checked when built).
layout(std140, binding = 4) uniform WaveParams {
  ivec4 active_rect;    // interior cells [x0, x1) x [y0, y1)
  ivec2 texel_origin;   // apply: page texel of interior cell (0, 0)
  int stride;           // width + 2
  int nu2_q16;          // step
  int damping_q16;      // step
  int w_pad0, w_pad1, w_pad2;
};

#ifdef PASS_STEP
layout(std430, binding = 2) readonly buffer WaveCur { int cur[]; };
layout(std430, binding = 3) buffer WavePrev { int prev[]; };  // becomes next

void main() {
  ivec2 c = active_rect.xy + ivec2(gl_GlobalInvocationID.xy);
  if (c.x >= active_rect.z || c.y >= active_rect.w) return;
  int i = (c.y + 1) * stride + c.x + 1;
  const int64_t round_half = int64_t(32768);
  const int64_t limit = int64_t(1073741824);
  int64_t w = int64_t(cur[i]);
  int64_t lap = int64_t(cur[i - 1]) + int64_t(cur[i + 1]) + int64_t(cur[i - stride]) +
                int64_t(cur[i + stride]) - int64_t(4) * w;
  int64_t v = w - int64_t(prev[i]);
  // >> on int64 is an arithmetic shift: floor division by 2^16, as the reference.
  int64_t next = w + v - ((v * int64_t(damping_q16) + round_half) >> 16) + ((lap * int64_t(nu2_q16) + round_half) >> 16);
  next = next < -limit ? -limit : (next > limit ? limit : next);
  prev[i] = int(next);
}
#endif

#ifdef PASS_APPLY
#ifdef LAYER_DETAIL
layout(r8i, binding = 0) uniform coherent iimage2D layer_image;
int load_sample(ivec2 p) { return imageLoad(layer_image, p).r; }
void store_sample(ivec2 p, int v) { imageStore(layer_image, p, ivec4(v, 0, 0, 0)); }
const int kLayerMin = -128, kLayerMax = 127;
#else
layout(r16ui, binding = 0) uniform coherent uimage2D layer_image;
int load_sample(ivec2 p) { return int(imageLoad(layer_image, p).r); }
void store_sample(ivec2 p, int v) { imageStore(layer_image, p, uvec4(uint(v), 0u, 0u, 0u)); }
const int kLayerMin = 0, kLayerMax = 65535;
#endif
layout(std430, binding = 2) readonly buffer WaveCur { int cur[]; };
// active_rect: the cells in this page.

void main() {
  ivec2 c = active_rect.xy + ivec2(gl_GlobalInvocationID.xy);
  if (c.x >= active_rect.z || c.y >= active_rect.w) return;
  int delta = (cur[(c.y + 1) * stride + c.x + 1] + 128) >> 8;  // round_q8
  if (delta == 0) return;
  ivec2 p = texel_origin + c;
  int old = load_sample(p);
  int nv = clamp(old + delta, kLayerMin, kLayerMax);
  if (nv == old) return;
  store_sample(p, nv);
}
#endif
