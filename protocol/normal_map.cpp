#include "protocol/normal_map.h"

#include <algorithm>
#include <cmath>

namespace loam {

namespace {

// The stencils of fd4_derivative (surface.cpp), written out on an array with the same
// operation order so the results are bit-identical.
double fd4(const double* f, int64_t i, int64_t lo, int64_t hi, int64_t stride, double h) {
  auto at = [&](int64_t k) { return f[k * stride]; };
  if (i - 2 >= lo && i + 2 < hi) {
    return (at(-2) - 8.0 * at(-1) + 8.0 * at(1) - at(2)) / (12.0 * h);
  }
  if (i - lo == 0) {
    return (-25.0 * at(0) + 48.0 * at(1) - 36.0 * at(2) + 16.0 * at(3) - 3.0 * at(4)) / (12.0 * h);
  }
  if (i - lo == 1) {
    return (-3.0 * at(-1) - 10.0 * at(0) + 18.0 * at(1) - 6.0 * at(2) + at(3)) / (12.0 * h);
  }
  if (hi - 1 - i == 0) {
    return (25.0 * at(0) - 48.0 * at(-1) + 36.0 * at(-2) - 16.0 * at(-3) + 3.0 * at(-4)) / (12.0 * h);
  }
  return (3.0 * at(1) + 10.0 * at(0) - 18.0 * at(-1) + 6.0 * at(-2) - at(-3)) / (12.0 * h);
}

int16_t snorm16(double v) {
  const double s = std::clamp(v, -1.0, 1.0) * 32767.0;
  return int16_t(s >= 0 ? int32_t(s + 0.5) : -int32_t(-s + 0.5));
}

}  // namespace

void coarse_gradients(const World& world, const RectI& rect, std::vector<double>& dhdx,
                      std::vector<double>& dhdy) {
  decimated_gradients(world, 0, rect, dhdx, dhdy);
}

void decimated_gradients(const World& world, int32_t mip, const RectI& rect, std::vector<double>& dhdx,
                         std::vector<double>& dhdy) {
  const WorldParams& p = world.params();
  const int64_t s = int64_t(1) << mip;
  const RectI w0 = p.sample_rect();
  // The world in the decimated grid: samples i with i * s inside it.
  const RectI w{ceil_div(w0.x0, s), ceil_div(w0.y0, s), ceil_div(w0.x1, s), ceil_div(w0.y1, s)};
  dhdx.assign(size_t(rect.area()), 0.0);
  dhdy.assign(size_t(rect.area()), 0.0);
  if (rect.empty()) return;
  // Samples the stencils may read: the rect (clamped into the world) grown by 4, in the world.
  const RectI clamped{std::clamp(rect.x0, w.x0, w.x1 - 1), std::clamp(rect.y0, w.y0, w.y1 - 1),
                      std::clamp(rect.x1, w.x0 + 1, w.x1), std::clamp(rect.y1, w.y0 + 1, w.y1)};
  const RectI block = RectI{clamped.x0 - 4, clamped.y0 - 4, clamped.x1 + 4, clamped.y1 + 4}.intersect(w);
  std::vector<uint16_t> q(size_t(block.area()));
  if (mip == 0) {
    world.read_coarse(block, q);
  } else {
    size_t i = 0;
    for (int64_t y = block.y0; y < block.y1; ++y) {
      for (int64_t x = block.x0; x < block.x1; ++x) q[i++] = world.coarse(x * s, y * s);
    }
  }
  std::vector<double> m(q.size());
  for (size_t i = 0; i < q.size(); ++i) m[i] = p.height_meters(q[i]);
  const int64_t bw = block.width();
  const double h = p.meters_per_sample * double(s);
  for (int64_t y = rect.y0; y < rect.y1; ++y) {
    const int64_t sy = std::clamp(y, w.y0, w.y1 - 1);
    for (int64_t x = rect.x0; x < rect.x1; ++x) {
      const int64_t sx = std::clamp(x, w.x0, w.x1 - 1);
      const double* f = m.data() + (sy - block.y0) * bw + (sx - block.x0);
      const size_t o = size_t((y - rect.y0) * rect.width() + (x - rect.x0));
      dhdx[o] = fd4(f, sx, w.x0, w.x1, 1, h);
      dhdy[o] = fd4(f, sy, w.y0, w.y1, bw, h);
    }
  }
}

uint32_t pack_normal(double dhdx, double dhdy) {
  const double nx = -dhdx, ny = -dhdy;
  const double len = std::sqrt(nx * nx + ny * ny + 1.0);
  return uint32_t(uint16_t(snorm16(nx / len))) | (uint32_t(uint16_t(snorm16(ny / len))) << 16);
}

void unpack_normal(uint32_t packed, double& nx, double& ny, double& nz) {
  nx = double(int16_t(uint16_t(packed & 0xFFFF))) / 32767.0;
  ny = double(int16_t(uint16_t(packed >> 16))) / 32767.0;
  nz = std::sqrt(std::max(0.0, 1.0 - nx * nx - ny * ny));
}

std::vector<uint32_t> generate_normal_map(const World& world, const RectI& rect) {
  return generate_decimated_normal_map(world, 0, rect);
}

std::vector<uint32_t> generate_decimated_normal_map(const World& world, int32_t mip, const RectI& rect) {
  std::vector<double> gx, gy;
  decimated_gradients(world, mip, rect, gx, gy);
  std::vector<uint32_t> out(gx.size());
  for (size_t i = 0; i < out.size(); ++i) out[i] = pack_normal(gx[i], gy[i]);
  return out;
}

}  // namespace loam
