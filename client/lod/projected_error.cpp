#include "client/lod/projected_error.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace loam::lod {

namespace {

using Vec = std::array<double, 3>;

double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec unit(const Vec& a) {
  const double n = std::sqrt(dot(a, a));
  return n > 0 ? Vec{a[0] / n, a[1] / n, a[2] / n} : Vec{0, 0, 0};
}

}  // namespace

void set_view_axes(LodView& view, const Vec& forward, const Vec& up_hint, double fov_y_degrees,
                   double aspect) {
  view.forward = unit(forward);
  view.right = unit(cross(view.forward, up_hint));
  view.up = cross(view.right, view.forward);
  view.half_tan_y = std::tan(fov_y_degrees * M_PI / 360.0);
  view.half_tan_x = view.half_tan_y * aspect;
}

double pixels_per_vertical_meter(const LodView& v, const Vec& lo, const Vec& hi) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const double d = box_distance(v.x, v.y, v.z, lo, hi);
  if (!(v.half_tan_x > 0)) return d > 0 ? v.pixels_per_radian / d : kInf;
  // The image's motion per meter up, times the depth, at screen position (sx, sy): convex in
  // (sx, sy) (the norm of an affine map), so its largest value over a rectangle is at a corner.
  const double zr = v.right[2], zu = v.up[2], zw = v.forward[2];
  auto motion = [&](double sx, double sy) { return std::hypot(zr - sx * zw, zu - sy * zw); };
  auto largest_motion = [&](double x0, double x1, double y0, double y1) {
    return std::max({motion(x0, y0), motion(x1, y0), motion(x0, y1), motion(x1, y1)});
  };
  double z_min = kInf, z_max = -kInf, sx0 = kInf, sx1 = -kInf, sy0 = kInf, sy1 = -kInf;
  for (int i = 0; i < 8; ++i) {
    const Vec p{(i & 1 ? hi : lo)[0] - v.x, (i & 2 ? hi : lo)[1] - v.y, (i & 4 ? hi : lo)[2] - v.z};
    const double z = dot(p, v.forward);
    z_min = std::min(z_min, z), z_max = std::max(z_max, z);
    if (z <= 0) continue;
    const double sx = dot(p, v.right) / z, sy = dot(p, v.up) / z;
    sx0 = std::min(sx0, sx), sx1 = std::max(sx1, sx), sy0 = std::min(sy0, sy), sy1 = std::max(sy1, sy);
  }
  const double tx = v.half_tan_x, ty = v.half_tan_y;
  if (z_max <= 0) return 0;  // wholly behind the eye
  if (z_min > 0) {
    // Wholly in front of the eye: its image lies in its corners' (a convex box's image is their
    // hull), and its depth is at least its nearest corner's.
    sx0 = std::max(sx0, -tx), sx1 = std::min(sx1, tx), sy0 = std::max(sy0, -ty), sy1 = std::min(sy1, ty);
    if (sx0 > sx1 || sy0 > sy1) return 0;
    return v.pixels_per_radian * largest_motion(sx0, sx1, sy0, sy1) / z_min;
  }
  // Across the eye's plane: a point on screen is at most the screen corner's angle off the
  // axis, so its depth is at least d cos(that angle).
  if (!(d > 0)) return kInf;
  const double cos_corner = 1.0 / std::sqrt(1.0 + tx * tx + ty * ty);
  return v.pixels_per_radian * largest_motion(-tx, tx, -ty, ty) / (d * cos_corner);
}

}  // namespace loam::lod
