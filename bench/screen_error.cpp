#include "bench/screen_error.h"

#include <algorithm>
#include <cmath>

#include "protocol/surface.h"

namespace loam::bench {

double truth_height(const World& world, double x, double y, Truth truth) {
  if (truth == Truth::kBilinear) return height_at(world, x, y);
  const WorldParams& p = world.params();
  int64_t i = 0, j = 0;
  double fx = 0, fy = 0;
  split_coordinate(x / p.meters_per_sample, i, fx);
  split_coordinate(y / p.meters_per_sample, j, fy);
  double h00 = p.height_meters(world.coarse(i, j)), h10 = p.height_meters(world.coarse(i + 1, j));
  double h01 = p.height_meters(world.coarse(i, j + 1)), h11 = p.height_meters(world.coarse(i + 1, j + 1));
  if (truth == Truth::kUnionJack && ((i ^ j) & 1) != 0) {
    // Split along (x + 1, y)-(x, y + 1): mirror x.
    std::swap(h00, h10);
    std::swap(h01, h11);
    fx = 1.0 - fx;
  }
  if (fx >= fy) return h00 + (h10 - h00) * fx + (h11 - h10) * fy;
  return h00 + (h01 - h00) * fy + (h11 - h01) * fx;
}

void add_screen_errors(const World& world, const scene::Camera& cam, int32_t w, int32_t h,
                       const std::vector<float>& depth, std::vector<double>& px_errors,
                       std::vector<double>& m_errors, Truth truth_kind) {
  const glm::mat4 vp = scene::view_projection(cam, w, h);
  // The world's extent in meters, less half a sample: a clipmap's earth skirt stands on the
  // edge and is no terrain to score.
  const WorldParams& wp = world.params();
  const RectI wr = wp.sample_rect();
  const double mps = wp.meters_per_sample;
  const double ex0 = (double(wr.x0) + 0.5) * mps, ex1 = (double(wr.x1 - 1) - 0.5) * mps;
  const double ey0 = (double(wr.y0) + 0.5) * mps, ey1 = (double(wr.y1 - 1) - 0.5) * mps;
  for (int32_t y = 0; y < h; ++y) {
    for (int32_t x = 0; x < w; ++x) {
      const auto p = scene::unproject(cam, w, h, x, y, depth[size_t(y) * size_t(w) + size_t(x)]);
      if (!p) continue;
      if ((*p)[0] < ex0 || (*p)[0] > ex1 || (*p)[1] < ey0 || (*p)[1] > ey1) continue;
      const double truth = truth_height(world, (*p)[0], (*p)[1], truth_kind);
      const glm::vec4 clip =
          vp * glm::vec4(float((*p)[0] - cam.x), float(-((*p)[1] - cam.y)), float(truth - cam.z), 1.0f);
      if (clip.w <= 0) continue;
      const double qx = (clip.x / clip.w + 1.0) * 0.5 * w - 0.5, qy = (1.0 - clip.y / clip.w) * 0.5 * h - 0.5;
      px_errors.push_back(std::hypot(qx - x, qy - y));
      m_errors.push_back(std::abs((*p)[2] - truth));
    }
  }
}

ErrorStats summarize_errors(std::vector<double>& px, const std::vector<double>& m) {
  ErrorStats s;
  s.pixels = int64_t(px.size());
  if (px.empty()) return s;
  std::sort(px.begin(), px.end());
  double sum = 0, sum_m = 0;
  for (double v : px) sum += v;
  for (double v : m) sum_m += v, s.max_m = std::max(s.max_m, v);
  s.mean_px = sum / double(px.size());
  s.p50_px = px[size_t(0.50 * double(px.size() - 1))];
  s.p99_px = px[size_t(0.99 * double(px.size() - 1))];
  s.max_px = px.back();
  s.mean_m = sum_m / double(m.size());
  return s;
}

}  // namespace loam::bench
