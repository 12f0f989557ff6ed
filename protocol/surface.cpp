#include "protocol/surface.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace loam {

void split_coordinate(double u, int64_t& index, double& frac) {
  const double r = std::nearbyint(u);
  if (std::fabs(u - r) <= 8.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::fabs(u))) {
    index = int64_t(r);
    frac = 0.0;
    return;
  }
  const double f = std::floor(u);
  index = int64_t(f);
  frac = u - f;
}

namespace {

template <typename Sample>
double bilinear(double u, double v, const Sample& sample) {
  int64_t i, j;
  double fx, fy;
  split_coordinate(u, i, fx);
  split_coordinate(v, j, fy);
  const double h00 = sample(i, j);
  if (fx == 0.0 && fy == 0.0) return h00;
  const double h10 = sample(i + 1, j), h01 = sample(i, j + 1), h11 = sample(i + 1, j + 1);
  return (1.0 - fy) * ((1.0 - fx) * h00 + fx * h10) + fy * ((1.0 - fx) * h01 + fx * h11);
}

}  // namespace

double height_at(const World& world, double x, double y) {
  const WorldParams& p = world.params();
  const double coarse = bilinear(x / p.meters_per_sample, y / p.meters_per_sample,
                                 [&](int64_t i, int64_t j) { return p.height_meters(world.coarse(i, j)); });
  if (world.detail_tile_count() == 0) return coarse;
  const double dm = p.detail_meters_per_sample();
  return coarse +
         bilinear(x / dm, y / dm, [&](int64_t i, int64_t j) { return p.detail_meters(world.detail(i, j)); });
}

double fd4_derivative(const std::function<double(int64_t)>& f, int64_t i, int64_t lo, int64_t hi, double h) {
  if (i - 2 >= lo && i + 2 < hi) {
    return (f(i - 2) - 8.0 * f(i - 1) + 8.0 * f(i + 1) - f(i + 2)) / (12.0 * h);
  }
  if (i - lo == 0) {
    return (-25.0 * f(i) + 48.0 * f(i + 1) - 36.0 * f(i + 2) + 16.0 * f(i + 3) - 3.0 * f(i + 4)) / (12.0 * h);
  }
  if (i - lo == 1) {
    return (-3.0 * f(i - 1) - 10.0 * f(i) + 18.0 * f(i + 1) - 6.0 * f(i + 2) + f(i + 3)) / (12.0 * h);
  }
  if (hi - 1 - i == 0) {
    return (25.0 * f(i) - 48.0 * f(i - 1) + 36.0 * f(i - 2) - 16.0 * f(i - 3) + 3.0 * f(i - 4)) / (12.0 * h);
  }
  return (3.0 * f(i + 1) + 10.0 * f(i) - 18.0 * f(i - 1) + 6.0 * f(i - 2) - f(i - 3)) / (12.0 * h);
}

Vec3d coarse_gradient_at_sample(const World& world, int64_t gx, int64_t gy) {
  const WorldParams& p = world.params();
  const RectI r = p.sample_rect();
  gx = std::clamp(gx, r.x0, r.x1 - 1);
  gy = std::clamp(gy, r.y0, r.y1 - 1);
  const double h = p.meters_per_sample;
  const double dx =
      fd4_derivative([&](int64_t i) { return p.height_meters(world.coarse(i, gy)); }, gx, r.x0, r.x1, h);
  const double dy =
      fd4_derivative([&](int64_t j) { return p.height_meters(world.coarse(gx, j)); }, gy, r.y0, r.y1, h);
  return {dx, dy, 0.0};
}

Vec3d detail_gradient_at_sample(const World& world, int64_t dxi, int64_t dyi) {
  const WorldParams& p = world.params();
  const RectI r = p.detail_sample_rect();
  dxi = std::clamp(dxi, r.x0, r.x1 - 1);
  dyi = std::clamp(dyi, r.y0, r.y1 - 1);
  const double h = p.detail_meters_per_sample();
  const double dx =
      fd4_derivative([&](int64_t i) { return p.detail_meters(world.detail(i, dyi)); }, dxi, r.x0, r.x1, h);
  const double dy =
      fd4_derivative([&](int64_t j) { return p.detail_meters(world.detail(dxi, j)); }, dyi, r.y0, r.y1, h);
  return {dx, dy, 0.0};
}

Vec3d normal_at(const World& world, double x, double y) {
  const WorldParams& p = world.params();
  const double gx = bilinear(x / p.meters_per_sample, y / p.meters_per_sample,
                             [&](int64_t i, int64_t j) { return coarse_gradient_at_sample(world, i, j).x; });
  const double gy = bilinear(x / p.meters_per_sample, y / p.meters_per_sample,
                             [&](int64_t i, int64_t j) { return coarse_gradient_at_sample(world, i, j).y; });
  double ddx = 0.0, ddy = 0.0;
  if (world.detail_tile_count() != 0) {
    const double dm = p.detail_meters_per_sample();
    ddx = bilinear(x / dm, y / dm,
                   [&](int64_t i, int64_t j) { return detail_gradient_at_sample(world, i, j).x; });
    ddy = bilinear(x / dm, y / dm,
                   [&](int64_t i, int64_t j) { return detail_gradient_at_sample(world, i, j).y; });
  }
  const double nx = -(gx + ddx), ny = -(gy + ddy), nz = 1.0;
  const double len = std::sqrt(nx * nx + ny * ny + nz * nz);
  return {nx / len, ny / len, nz / len};
}

}  // namespace loam
