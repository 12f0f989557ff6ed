// Terrains, views and the screen-error measure the level-of-detail scheme tests share
// (geomipmap_test.cpp, quadtree_lod_test.cpp): a rough world of any size with hills, a ridge
// and a cliff, a flat one, 2 m samples of 5 cm units, and views at 1080 pixels, 60 degrees.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "client/lod/geomipmap.h"

namespace loam::lod::test {

struct Terrain {
  int64_t width, height;
  std::vector<uint16_t> samples;
  HeightGrid grid() const { return {samples, width, height}; }
};

// Hills, a ridge and a cliff, and a little noise: every level has error somewhere.
inline Terrain rough(int64_t w, int64_t h, uint32_t seed) {
  std::mt19937 rng(seed);
  Terrain t{w, h, std::vector<uint16_t>(size_t(w * h))};
  for (int64_t y = 0; y < h; ++y) {
    for (int64_t x = 0; x < w; ++x) {
      double v = 20000 + 6000 * std::sin(double(x) * 0.05) * std::cos(double(y) * 0.07) + double(rng() % 6);
      if (x > w / 2 && x < w / 2 + 6) v += 8000;  // a ridge
      if (y > h / 3) v += 3000;                   // a cliff
      t.samples[size_t(y * w + x)] = uint16_t(std::clamp(v, 0.0, 65535.0));
    }
  }
  return t;
}

inline Terrain flat(int64_t w, int64_t h) { return {w, h, std::vector<uint16_t>(size_t(w * h), 12345)}; }

inline const HeightScale kScale{2.0, 0.05, -500.0};  // 2 m samples, 5 cm units

inline LodView view_at(double x, double y, double z, double tolerance_px = 2.0) {
  LodView v;
  v.x = x, v.y = y, v.z = z;
  v.pixels_per_radian = pixels_per_radian(1080, 60.0);
  v.tolerance_px = tolerance_px;
  return v;
}

// The largest screen error (px) of a drawn surface (height units at every covered sample,
// rows of `covered_width`) at the world's samples, seen from the view at each sample's
// distance; the largest vertical error (m) too.
inline double worst_screen_error(const std::vector<float>& surface, int64_t covered_width, const Terrain& t,
                                 const LodView& v, double* vertical_m = nullptr) {
  double worst = 0, worst_m = 0;
  for (int64_t y = 0; y < t.height; ++y) {
    for (int64_t x = 0; x < t.width; ++x) {
      const uint16_t h = t.samples[size_t(y * t.width + x)];
      const double err_m =
          std::abs(double(surface[size_t(y * covered_width + x)]) - double(h)) * kScale.meters_per_unit;
      const double dx = double(x) * kScale.meters_per_sample - v.x,
                   dy = double(y) * kScale.meters_per_sample - v.y;
      const double dz = kScale.meters(h) - v.z;
      worst = std::max(worst, err_m * v.pixels_per_radian / std::sqrt(dx * dx + dy * dy + dz * dz));
      worst_m = std::max(worst_m, err_m);
    }
  }
  if (vertical_m) *vertical_m = worst_m;
  return worst;
}

// The largest change (m) of the drawn surface between consecutive views of a camera climbing
// 5 m per step from 500 m while drifting, with a 3 px budget: blocks and patches pass several
// level switches. `surface(view)` is the drawn surface for a view (height units).
inline double largest_surface_step(int steps,
                                   const std::function<std::vector<float>(const LodView&)>& surface) {
  double worst = 0;
  std::vector<float> prev;
  for (int step = 0; step <= steps; ++step) {
    const auto now = surface(view_at(200 + step * 0.8, 150 + step * 0.6, 500 + step * 5.0, 3.0));
    for (size_t i = 0; i < now.size() && !prev.empty(); ++i)
      worst = std::max(worst, double(std::abs(now[i] - prev[i])) * kScale.meters_per_unit);
    prev = now;
  }
  return worst;
}

}  // namespace loam::lod::test
