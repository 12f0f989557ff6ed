// Normal map of a rect of the coarse layer: protocol/normal_map.cpp's FD4 gradients and
// packing, mirrored in double precision. Every intermediate is `precise` so the compiler may
// not fuse multiply-adds or reorder: the operation order is the reference's, term by term.
// Output: one uint per sample, bits 0..15 nx and 16..31 ny as signed Q15 (normal_map.h's
// RG16_SNORM packing; unpackSnorm2x16 reads it back, nz = sqrt(1 - nx^2 - ny^2)).
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform usampler2D heights;  // R16UI, the whole coarse layer
layout(r32ui, binding = 1) uniform writeonly uimage2D normals;

uniform ivec2 world_size;  // layer texels
uniform ivec4 rect;        // texels [x0, x1) x [y0, y1), inside the world
uniform double height_offset;
uniform double meters_per_unit;
uniform double spacing;  // meters per sample

double meters(ivec2 p) {
  precise double m = height_offset + double(texelFetch(heights, p, 0).r) * meters_per_unit;
  return m;
}

// fd4_derivative along `axis` at index i on [0, n).
double fd4(ivec2 p, ivec2 axis, int i, int n) {
  precise double r;
  precise double den = 12.0 * spacing;
  if (i - 2 >= 0 && i + 2 < n) {
    precise double a = meters(p - 2 * axis), b = meters(p - axis), c = meters(p + axis), d = meters(p + 2 * axis);
    r = (a - 8.0 * b + 8.0 * c - d) / den;
  } else if (i == 0) {
    precise double f0 = meters(p), f1 = meters(p + axis), f2 = meters(p + 2 * axis), f3 = meters(p + 3 * axis),
                   f4 = meters(p + 4 * axis);
    r = (-25.0 * f0 + 48.0 * f1 - 36.0 * f2 + 16.0 * f3 - 3.0 * f4) / den;
  } else if (i == 1) {
    precise double fm = meters(p - axis), f0 = meters(p), f1 = meters(p + axis), f2 = meters(p + 2 * axis),
                   f3 = meters(p + 3 * axis);
    r = (-3.0 * fm - 10.0 * f0 + 18.0 * f1 - 6.0 * f2 + f3) / den;
  } else if (n - 1 - i == 0) {
    precise double f0 = meters(p), f1 = meters(p - axis), f2 = meters(p - 2 * axis), f3 = meters(p - 3 * axis),
                   f4 = meters(p - 4 * axis);
    r = (25.0 * f0 - 48.0 * f1 + 36.0 * f2 - 16.0 * f3 + 3.0 * f4) / den;
  } else {
    precise double fp = meters(p + axis), f0 = meters(p), f1 = meters(p - axis), f2 = meters(p - 2 * axis),
                   f3 = meters(p - 3 * axis);
    r = (3.0 * fp + 10.0 * f0 - 18.0 * f1 + 6.0 * f2 - f3) / den;
  }
  return r;
}

uint snorm16(double v) {
  precise double s = clamp(v, -1.0, 1.0) * 32767.0;
  int q = s >= 0.0 ? int(s + 0.5) : -int(-s + 0.5);
  return uint(q) & 0xFFFFu;
}

void main() {
  ivec2 p = rect.xy + ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= rect.z || p.y >= rect.w) return;
  precise double nx = -fd4(p, ivec2(1, 0), p.x, world_size.x);
  precise double ny = -fd4(p, ivec2(0, 1), p.y, world_size.y);
  precise double len = sqrt(nx * nx + ny * ny + 1.0);
  precise double ux = nx / len;
  precise double uy = ny / len;
  imageStore(normals, p, uvec4(snorm16(ux) | (snorm16(uy) << 16), 0u, 0u, 0u));
}
