// The per-sample stamp kernel in a compute shader (stamp_common.glsl is prepended): each
// invocation stamps STAMP_ROWS samples of one column of the stamp's rect, updated in place
// through image load/store (each sample reads only itself, so no ping-pong is needed, and
// compute runs every invocation exactly once). Several samples per invocation amortize the
// per-invocation cost (on llvmpipe, a coroutine per lane group). No atomics per changed
// sample: they serialize on llvmpipe; the host finds the changed rect while it copies the
// readback.
//
// Defines (besides stamp_common.glsl's): one of PASS_STAMP, PASS_CONTACT (footprint
// pre-pass: first point of contact, reduced per workgroup, then one atomic per workgroup),
// PASS_WAVE_INIT (shockwave: the Gaussian pulse into the wave field); STAMP_ROWS.
layout(local_size_x = 8, local_size_y = 8) in;

#ifdef LAYER_DETAIL
layout(r8i, binding = 0) uniform iimage2D layer_image;
int load_sample(ivec2 p) { return imageLoad(layer_image, p).r; }
void store_sample(ivec2 p, int v) { imageStore(layer_image, p, ivec4(v, 0, 0, 0)); }
#else
layout(r16ui, binding = 0) uniform uimage2D layer_image;
int load_sample(ivec2 p) { return int(imageLoad(layer_image, p).r); }
void store_sample(ivec2 p, int v) { imageStore(layer_image, p, uvec4(uint(v), 0u, 0u, 0u)); }
#endif

// Footprint: the first point of contact (gathered by PASS_CONTACT, read by PASS_STAMP).
layout(std430, binding = 1) coherent buffer StampResult { int contact_q8; };

#ifdef PASS_WAVE_INIT
layout(std430, binding = 2) writeonly buffer WaveCur { int wave_cur[]; };
layout(std430, binding = 3) writeonly buffer WavePrev { int wave_prev[]; };
#endif

#ifdef PASS_CONTACT
shared int group_contact;
#endif

void main() {
  const Stamp s = load_stamp();
#if defined(PASS_WAVE_INIT)
  const int stride = p_wave.x, ox = p_wave.y, oy = p_wave.z;
  for (int j = 0; j < STAMP_ROWS; ++j) {
    ivec2 l = ivec2(gl_GlobalInvocationID.x, int(gl_GlobalInvocationID.y) * STAMP_ROWS + j);
    int u = radial_u(s, l);
    if (l.x < s.size.x && l.y < s.size.y && u >= 0) {
      int w0 = table_lookup(u);
      int at = (l.y + oy + 1) * stride + (l.x + ox + 1);
      wave_cur[at] = w0;
      wave_prev[at] = w0;  // at rest
    }
  }
#elif defined(PASS_CONTACT)
  if (gl_LocalInvocationIndex == 0u) group_contact = kNoContact;
  barrier();
  int best = kNoContact;
  for (int j = 0; j < STAMP_ROWS; ++j) {
    ivec2 l = ivec2(gl_GlobalInvocationID.x, int(gl_GlobalInvocationID.y) * STAMP_ROWS + j);
    int c = contact_value(s, l, load_sample(s.origin + l));
    best = l.x < s.size.x && l.y < s.size.y ? max(best, c) : best;
  }
  if (best != kNoContact) atomicMax(group_contact, best);
  barrier();
  if (gl_LocalInvocationIndex == 0u && group_contact != kNoContact) atomicMax(contact_q8, group_contact);
#else
#if KIND_NEEDS_CONTACT
  const int contact = contact_q8;
#else
  const int contact = kNoContact;
#endif
  for (int j = 0; j < STAMP_ROWS; ++j) {
    ivec2 l = ivec2(gl_GlobalInvocationID.x, int(gl_GlobalInvocationID.y) * STAMP_ROWS + j);
    ivec2 p = s.origin + l;
    int old = load_sample(p);
    int nv = stamp_sample(s, l, old, contact);
    if (l.x < s.size.x && l.y < s.size.y && nv != old) store_sample(p, nv);
  }
#endif
}
