// The per-sample stamp kernel in a vertex shader (stamp_common.glsl is prepended), for
// small stamps on a software renderer: llvmpipe runs the vertex stage on the calling thread,
// while every compute dispatch is handed to its worker threads and waited for, a cross-core
// wake-up that costs more than a whole small stamp. One point per run of STAMP_RUN samples
// of a row of the stamp's rect (gl_VertexID = row * runs + run), placed outside the clip
// volume so nothing is rasterized; the program has no fragment stage.
//
// A vertex shader may run more than once per vertex, so the pass is idempotent: it reads
// the old samples from a copy of the rect (old_image, rect-local texels, made by the host
// just before) and only writes the layer, never reading what it writes.
//
// Defines (besides stamp_common.glsl's): PASS_STAMP or PASS_CONTACT (footprint pre-pass:
// the maximum over the run, then one atomic per point; atomicMax is idempotent too);
// STAMP_RUN.

#ifdef LAYER_DETAIL
layout(r8i, binding = 0) uniform writeonly iimage2D layer_image;
layout(r8i, binding = 1) uniform readonly iimage2D old_image;
int load_old(ivec2 l) { return imageLoad(old_image, l).r; }
void store_sample(ivec2 p, int v) { imageStore(layer_image, p, ivec4(v, 0, 0, 0)); }
#else
layout(r16ui, binding = 0) uniform writeonly uimage2D layer_image;
layout(r16ui, binding = 1) uniform readonly uimage2D old_image;
int load_old(ivec2 l) { return int(imageLoad(old_image, l).r); }
void store_sample(ivec2 p, int v) { imageStore(layer_image, p, uvec4(uint(v), 0u, 0u, 0u)); }
#endif

layout(std430, binding = 1) coherent buffer StampResult { int contact_q8; };

void main() {
  const Stamp s = load_stamp();
  const int runs = p_misc.w;  // runs per row, >= 1
  gl_Position = vec4(2.0, 2.0, 0.0, 1.0);  // outside the clip volume
  const int row = gl_VertexID / runs;  // one divide per point, not per sample
  const int x0 = (gl_VertexID - row * runs) * STAMP_RUN;
#ifdef PASS_CONTACT
  int best = kNoContact;
  for (int j = 0; j < STAMP_RUN; ++j) {
    ivec2 l = ivec2(x0 + j, row);
    int c = contact_value(s, l, load_old(l));
    best = l.x < s.size.x ? max(best, c) : best;
  }
  if (best != kNoContact) atomicMax(contact_q8, best);
#else
#if KIND_NEEDS_CONTACT
  const int contact = contact_q8;
#else
  const int contact = kNoContact;
#endif
  for (int j = 0; j < STAMP_RUN; ++j) {
    ivec2 l = ivec2(x0 + j, row);
    int old = load_old(l);
    int nv = stamp_sample(s, l, old, contact);
    if (l.x < s.size.x && nv != old) store_sample(s.origin + l, nv);
  }
#endif
}
