// FD4 normals shared by the world normal pass (normals.comp.glsl) and the clipmap level pass
// (level_normals.comp.glsl): protocol/normal_map.cpp's 4th-order gradients (one-sided
// stencils at the world's edges) and packing, in double precision with the reference's
// operation order (every intermediate `precise`: no fused multiply-adds, no reordering).
// The including shader defines height_m(p), the height in meters of its sample p.
// Output packing: bits 0..15 nx and 16..31 ny as signed Q15 (round(n * 32767));
// unpackSnorm2x16 reads it back, nz = sqrt(1 - nx^2 - ny^2).
double height_m(ivec2 p);

#ifdef NORMAL_PARAMS_PER_LEVEL
// Set by the including shader for the level its invocation computes (the level passes that
// follow a stamp: every level in one dispatch, level_event.glsl).
ivec4 n_rect;
ivec2 n_world_lo, n_world_size, n_region_lo, n_region_base;
int n_tex_size;
double n_height_offset, n_meters_per_unit, n_spacing;
#else
// The normal passes' parameters (gpu/normal_pass.h, NormalBlock; std140, checked member by
// member when the program is built). The world pass leaves the level fields 0.
layout(std140, binding = 3) uniform NormalParams {
  ivec4 n_rect;           // samples [x0, x1) x [y0, y1) to compute
  ivec2 n_world_lo;       // the world's first sample (level pass; world pass: 0)
  ivec2 n_world_size;     // the world in samples
  ivec2 n_region_lo;      // level pass: the region's first sample
  ivec2 n_region_base;    // level pass: its texel, region_lo mod tex_size
  int n_tex_size;         // level pass: the toroidal texture's side
  int n_pad0;
  double n_height_offset; // meters at unit 0
  double n_meters_per_unit;
  double n_spacing;       // meters between samples
};
#endif

// fd4_derivative along `axis` at index i on [0, n).
double fd4(ivec2 p, ivec2 axis, int i, int n) {
  precise double r;
  precise double den = 12.0 * n_spacing;
  if (i - 2 >= 0 && i + 2 < n) {
    precise double a = height_m(p - 2 * axis), b = height_m(p - axis), c = height_m(p + axis), d = height_m(p + 2 * axis);
    r = (a - 8.0 * b + 8.0 * c - d) / den;
  } else if (i == 0) {
    precise double f0 = height_m(p), f1 = height_m(p + axis), f2 = height_m(p + 2 * axis), f3 = height_m(p + 3 * axis),
                   f4 = height_m(p + 4 * axis);
    r = (-25.0 * f0 + 48.0 * f1 - 36.0 * f2 + 16.0 * f3 - 3.0 * f4) / den;
  } else if (i == 1) {
    precise double fm = height_m(p - axis), f0 = height_m(p), f1 = height_m(p + axis), f2 = height_m(p + 2 * axis),
                   f3 = height_m(p + 3 * axis);
    r = (-3.0 * fm - 10.0 * f0 + 18.0 * f1 - 6.0 * f2 + f3) / den;
  } else if (n - 1 - i == 0) {
    precise double f0 = height_m(p), f1 = height_m(p - axis), f2 = height_m(p - 2 * axis), f3 = height_m(p - 3 * axis),
                   f4 = height_m(p - 4 * axis);
    r = (25.0 * f0 - 48.0 * f1 + 36.0 * f2 - 16.0 * f3 + 3.0 * f4) / den;
  } else {
    precise double fp = height_m(p + axis), f0 = height_m(p), f1 = height_m(p - axis), f2 = height_m(p - 2 * axis),
                   f3 = height_m(p - 3 * axis);
    r = (3.0 * fp + 10.0 * f0 - 18.0 * f1 + 6.0 * f2 - f3) / den;
  }
  return r;
}

uint snorm16(double v) {
  precise double s = clamp(v, -1.0, 1.0) * 32767.0;
  int q = s >= 0.0 ? int(s + 0.5) : -int(-s + 0.5);
  return uint(q) & 0xFFFFu;
}

// The packed unit normal (-dh/dx, -dh/dy, 1) / |...| of sample p, whose index in the world's
// samples is `index` of `size` (for the one-sided stencils at the edges).
uint fd4_normal_packed(ivec2 p, ivec2 index, ivec2 size) {
  precise double nx = -fd4(p, ivec2(1, 0), index.x, size.x);
  precise double ny = -fd4(p, ivec2(0, 1), index.y, size.y);
  precise double len = sqrt(nx * nx + ny * ny + 1.0);
  precise double ux = nx / len;
  precise double uy = ny / len;
  return snorm16(ux) | (snorm16(uy) << 16);
}
