#include "bench/suites/codec_eval_set.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

namespace loam::bench {
namespace {

// A value in [0, 1) from integer coordinates and a seed (splitmix64).
double hash01(int64_t x, int64_t y, uint64_t seed) {
  uint64_t z = uint64_t(x) * 0x9E3779B97F4A7C15ull ^ uint64_t(y) * 0xC2B2AE3D27D4EB4Full ^ seed;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return double(z >> 11) * 0x1.0p-53;
}

// Smoothly interpolated value noise at (x, y) in cells of size 1, in [-1, 1].
double value_noise(double x, double y, uint64_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = int64_t(fx), iy = int64_t(fy);
  const double tx = x - fx, ty = y - fy;
  const double sx = tx * tx * (3 - 2 * tx), sy = ty * ty * (3 - 2 * ty);
  auto v = [&](int64_t a, int64_t b) { return 2.0 * hash01(a, b, seed) - 1.0; };
  const double top = v(ix, iy) + (v(ix + 1, iy) - v(ix, iy)) * sx;
  const double bottom = v(ix, iy + 1) + (v(ix + 1, iy + 1) - v(ix, iy + 1)) * sx;
  return top + (bottom - top) * sy;
}

// Fractional Brownian motion: `octaves` of value noise, each twice as fine and `gain` as strong.
double fbm(double x, double y, int octaves, double gain, uint64_t seed) {
  double sum = 0, amp = 1, norm = 0;
  for (int o = 0; o < octaves; ++o) {
    sum += amp * value_noise(x, y, seed + uint64_t(o) * 7919);
    norm += amp;
    amp *= gain;
    x *= 2.0;
    y *= 2.0;
  }
  return sum / norm;
}

// Heights quantized to multiples of `step` metres, as an integer source of that step.
DemRaster raster(const std::string& name, int64_t w, int64_t h, double spacing, double step,
                 const std::function<double(int64_t, int64_t)>& height) {
  DemRaster r;
  r.name = name;
  r.width = w;
  r.height = h;
  r.meters_per_sample = spacing;
  r.integer_source = true;
  r.vertical_step = step;
  r.scale_source = "explicit";
  r.format = "generated";
  r.sample_type = "int32";
  r.meters.resize(size_t(w * h));
  for (int64_t y = 0; y < h; ++y)
    for (int64_t x = 0; x < w; ++x) r.meters[size_t(y * w + x)] = std::round(height(x, y) / step) * step;
  return r;
}

// Catmull-Rom sample of `src` (metres, w x h) at (x, y) in source samples, clamped at the edges.
double cubic_at(const DemRaster& src, double x, double y) {
  auto at = [&](int64_t a, int64_t b) {
    a = std::clamp<int64_t>(a, 0, src.width - 1);
    b = std::clamp<int64_t>(b, 0, src.height - 1);
    return src.meters[size_t(b * src.width + a)];
  };
  auto cr = [](double p0, double p1, double p2, double p3, double t) {
    return p1 + 0.5 * t * (p2 - p0 + t * (2 * p0 - 5 * p1 + 4 * p2 - p3 + t * (3 * (p1 - p2) + p3 - p0)));
  };
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = int64_t(fx), iy = int64_t(fy);
  double rows[4];
  for (int j = 0; j < 4; ++j)
    rows[j] = cr(at(ix - 1, iy - 1 + j), at(ix, iy - 1 + j), at(ix + 1, iy - 1 + j), at(ix + 2, iy - 1 + j),
                 x - fx);
  return cr(rows[0], rows[1], rows[2], rows[3], y - fy);
}

}  // namespace

std::vector<EvalDem> codec_evaluation_set(const std::string& shared_data_dir,
                                          std::vector<std::string>& skipped) {
  std::vector<EvalDem> out;
  auto add = [&](const std::string& what, const DemRaster& r) {
    auto imported = import_dem(r);
    if (!imported) {
      skipped.push_back(r.name + " (" + imported.error().describe() + ")");
      return;
    }
    out.push_back({r.name, what, std::move(*imported)});
  };
  auto shared = [&](const std::string& file) -> std::optional<DemRaster> {
    const std::string path = (std::filesystem::path(shared_data_dir) / file).string();
    auto dem = read_dem_file(path);
    if (!dem) {
      skipped.push_back(file + " windows (" + dem.error().describe() + ")");
      return std::nullopt;
    }
    return std::move(*dem);
  };

  // Windows of the shared DEMs, resampled off their grid and quantized at other steps.
  if (auto etopo = shared("etopo5_global_4320x2161.png")) {
    // The Andes around 20 S (the tuning set holds the whole globe at 0.5 m units and a crop
    // elsewhere): 1.7x finer by Catmull-Rom, at 0.1 m.
    const double x0 = 3420, y0 = 1300;
    add("ETOPO5 window over the Andes (18 to 43 S, 75 to 41 W), resampled 1.7x finer (Catmull-Rom), 0.1 m units, 5.4 km "
        "spacing",
        raster("eval_etopo5_andes_0.1m", 700, 500, 9246.0 / 1.7, 0.1, [&](int64_t x, int64_t y) {
          return cubic_at(*etopo, x0 + double(x) / 1.7, y0 + double(y) / 1.7);
        }));
  }
  if (auto front = shared("frontrange_srtm3_758.png")) {
    add("Front Range window resampled 2.3x finer (Catmull-Rom), 1 cm units, 35 m spacing",
        raster("eval_frontrange_1cm", 520, 610, 81.06 / 2.3, 0.01, [&](int64_t x, int64_t y) {
          return cubic_at(*front, 200.0 + double(x) / 2.3, 150.0 + double(y) / 2.3);
        }));
  }
  if (auto kil = shared("kilauea_utm30m_857x793.png")) {
    // One tile's worth and an apron: 200 x 150 of the summit, 1 m units.
    add("Kilauea summit window, 200 x 150 (one tile with its apron), 1 m units, 30 m spacing",
        raster("eval_kilauea_tile_1m", 200, 150, 30.0, 1.0,
               [&](int64_t x, int64_t y) { return kil->meters[size_t((300 + y) * kil->width + 400 + x)]; }));
  }
  // Synthetic terrain.
  add("fBm (value noise, 9 octaves, gain 0.5), 800 m of relief, 0.1 m units, 20 m spacing",
      raster("eval_fbm_0.1m", 700, 520, 20.0, 0.1, [](int64_t x, int64_t y) {
        return 400.0 + 800.0 * fbm(double(x) / 180.0, double(y) / 180.0, 9, 0.5, 11);
      }));
  {
    // fBm worn by thermal erosion: material moves downhill wherever the slope passes a talus
    // angle, 60 passes, which leaves smooth debris slopes below sharp ridges.
    const int64_t n = 512;
    std::vector<double> h(size_t(n * n));
    for (int64_t y = 0; y < n; ++y)
      for (int64_t x = 0; x < n; ++x)
        h[size_t(y * n + x)] = 300.0 + 600.0 * fbm(double(x) / 150.0, double(y) / 150.0, 8, 0.55, 23);
    const double talus = 4.0;  // metres per sample (10 m spacing: about 22 degrees)
    std::vector<double> delta(h.size());
    for (int pass = 0; pass < 60; ++pass) {
      std::fill(delta.begin(), delta.end(), 0.0);
      for (int64_t y = 1; y + 1 < n; ++y) {
        for (int64_t x = 1; x + 1 < n; ++x) {
          const double c = h[size_t(y * n + x)];
          for (const auto& [dx, dy] : {std::pair{1, 0}, std::pair{-1, 0}, std::pair{0, 1}, std::pair{0, -1}}) {
            const size_t k = size_t((y + dy) * n + x + dx);
            const double d = c - h[k];
            if (d > talus) {
              const double move = 0.1 * (d - talus);
              delta[size_t(y * n + x)] -= move;
              delta[k] += move;
            }
          }
        }
      }
      for (size_t i = 0; i < h.size(); ++i) h[i] += delta[i];
    }
    add("fBm worn by 60 passes of thermal erosion (talus 4 m a sample), 1 cm units, 10 m spacing",
        raster("eval_eroded_1cm", n, n, 10.0, 0.01,
               [&](int64_t x, int64_t y) { return h[size_t(y * n + x)]; }));
  }
  add("ridged multifractal (1 - |noise|, squared, 7 octaves), 1500 m of relief, 1 m units, 90 m spacing",
      raster("eval_ridged_1m", 600, 600, 90.0, 1.0, [](int64_t x, int64_t y) {
        double sum = 0, amp = 1, fx = double(x) / 120.0, fy = double(y) / 120.0;
        for (int o = 0; o < 7; ++o) {
          const double r = 1.0 - std::fabs(value_noise(fx, fy, 31 + uint64_t(o)));
          sum += amp * r * r;
          amp *= 0.5;
          fx *= 2.0;
          fy *= 2.0;
        }
        return 200.0 + 800.0 * sum;
      }));
  add("terraces: fBm cut into 5 m steps with 1 m risers, 0.1 m units, 2 m spacing",
      raster("eval_terraces_0.1m", 640, 400, 2.0, 0.1, [](int64_t x, int64_t y) {
        const double v = 120.0 + 60.0 * fbm(double(x) / 160.0, double(y) / 160.0, 6, 0.5, 41);
        const double step = std::floor(v / 5.0), frac = v / 5.0 - step;
        return 5.0 * step + 5.0 * std::clamp((frac - 0.8) / 0.2, 0.0, 1.0);
      }));
  add("nearly flat: a plane rising 1 cm in 100 m with 1 cm of noise, 1 cm units, 5 m spacing",
      raster("eval_flat_1cm", 400, 300, 5.0, 0.01, [](int64_t x, int64_t y) {
        return 50.0 + 0.0005 * double(x) + 0.01 * std::floor(3.0 * hash01(x, y, 53));
      }));
  add("white noise: every sample uniform in 0..4000 m, 1 m units, 30 m spacing",
      raster("eval_white_noise_1m", 300, 260, 30.0, 1.0,
             [](int64_t x, int64_t y) { return 4000.0 * hash01(x, y, 61); }));
  return out;
}

Result<std::vector<EvalManifestEntry>> read_eval_manifest(const std::string& path) {
  std::ifstream in(path);
  if (!in) return make_error(ErrorCode::kNotFound, path, "cannot open the evaluation set's manifest");
  std::vector<EvalManifestEntry> out;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    EvalManifestEntry e;
    std::string hash;
    const bool split = bool(std::getline(fields, e.name, '\t')) && bool(std::getline(fields, hash, '\t'));
    const bool hex = hash.size() == 16 && std::all_of(hash.begin(), hash.end(), [](char c) {
                       return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
                     });
    if (!split || !hex) {
      return make_error(ErrorCode::kCorrupt, path,
                        "line " + std::to_string(number) + ": not NAME<tab>HASH...");
    }
    e.world_hash = std::stoull(hash, nullptr, 16);
    out.push_back(e);
  }
  return out;
}

std::string eval_manifest_line(const EvalDem& d) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%016llx", (unsigned long long)d.imported.world.world_hash());
  return d.name + "\t" + buf + "\t" + std::to_string(d.imported.report.width) + "x" +
         std::to_string(d.imported.report.height) + "\t" + d.what;
}

}  // namespace loam::bench
