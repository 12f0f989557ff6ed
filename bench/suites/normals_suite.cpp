// Suite `normals`: how exact each way of taking terrain normals from a height grid is, and what
// it costs. On analytic surfaces whose steepest slope grows from 5 to 85 degrees (products of
// sines, sampled at 1 m, 16 and 64 samples per wavelength), the angle between each method's
// normal and the true one at every sample:
//   - FD2, central differences (two samples per axis);
//   - FD4, the fourth-order central differences Loam uses (protocol/surface.h), and Loam's
//     packed RG16 normal of them (protocol/normal_map.h);
//   - Horn's 3 x 3 weighted differences, as `gdaldem slope|hillshade -alg Horn` computes them;
//   - the 8-bit partial-derivative format of the deformable-terrain paper: central differences
//     stored as two signed 8-bit slopes in [-1, 1], which cannot hold a slope past 45 degrees.
// Heights exact, and quantized to 5 cm (a typical height unit of Loam's worlds). Cost: CPU
// nanoseconds per texel over a 1024^2 grid, one core, and Loam's production CPU path.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "bench/harness.h"
#include "protocol/normal_map.h"
#include "protocol/surface.h"
#include "protocol/world.h"

namespace loam::bench {
namespace {

// A square height grid (m), spacing 1 m.
struct Grid {
  int64_t n = 0;
  std::vector<double> h;
  double at(int64_t x, int64_t y) const { return h[size_t(y * n + x)]; }
};

// h = A sin(kx) sin(ky), A k = tan(slope): the steepest slope is `slope_deg`.
struct Sines {
  double k, a;
  Sines(double wavelength, double slope_deg)
      : k(2.0 * M_PI / wavelength), a(std::tan(slope_deg * M_PI / 180.0) / k) {}
  double height(double x, double y) const { return a * std::sin(k * x) * std::sin(k * y); }
  void gradient(double x, double y, double& gx, double& gy) const {
    gx = a * k * std::cos(k * x) * std::sin(k * y);
    gy = a * k * std::sin(k * x) * std::cos(k * y);
  }
};

Grid sample(const Sines& s, int64_t n, double quantum) {
  Grid g{n, std::vector<double>(size_t(n * n))};
  for (int64_t y = 0; y < n; ++y)
    for (int64_t x = 0; x < n; ++x) {
      double v = s.height(double(x), double(y));
      if (quantum > 0) v = std::round(v / quantum) * quantum;
      g.h[size_t(y * n + x)] = v;
    }
  return g;
}

// A method: the unit normal at interior sample (x, y) (at least 2 samples from the edge).
struct Method {
  std::string name;
  std::function<void(const Grid&, int64_t, int64_t, double&, double&, double&)> normal;
};

void from_gradient(double gx, double gy, double& nx, double& ny, double& nz) {
  const double l = std::sqrt(gx * gx + gy * gy + 1.0);
  nx = -gx / l, ny = -gy / l, nz = 1.0 / l;
}

std::vector<Method> methods() {
  auto fd4 = [](const Grid& g, int64_t x, int64_t y, double& gx, double& gy) {
    gx = fd4_derivative([&](int64_t i) { return g.at(i, y); }, x, 0, g.n, 1.0);
    gy = fd4_derivative([&](int64_t j) { return g.at(x, j); }, y, 0, g.n, 1.0);
  };
  return {
      {"FD2",
       [](const Grid& g, int64_t x, int64_t y, double& nx, double& ny, double& nz) {
         from_gradient((g.at(x + 1, y) - g.at(x - 1, y)) / 2.0, (g.at(x, y + 1) - g.at(x, y - 1)) / 2.0, nx,
                       ny, nz);
       }},
      {"FD4",
       [fd4](const Grid& g, int64_t x, int64_t y, double& nx, double& ny, double& nz) {
         double gx = 0, gy = 0;
         fd4(g, x, y, gx, gy);
         from_gradient(gx, gy, nx, ny, nz);
       }},
      {"FD4, packed RG16 (Loam's normal maps)",
       [fd4](const Grid& g, int64_t x, int64_t y, double& nx, double& ny, double& nz) {
         double gx = 0, gy = 0;
         fd4(g, x, y, gx, gy);
         unpack_normal(pack_normal(gx, gy), nx, ny, nz);
       }},
      {"Horn 3x3 (gdaldem)",
       [](const Grid& g, int64_t x, int64_t y, double& nx, double& ny, double& nz) {
         const double gx = ((g.at(x + 1, y - 1) + 2 * g.at(x + 1, y) + g.at(x + 1, y + 1)) -
                            (g.at(x - 1, y - 1) + 2 * g.at(x - 1, y) + g.at(x - 1, y + 1))) /
                           8.0;
         const double gy = ((g.at(x - 1, y + 1) + 2 * g.at(x, y + 1) + g.at(x + 1, y + 1)) -
                            (g.at(x - 1, y - 1) + 2 * g.at(x, y - 1) + g.at(x + 1, y - 1))) /
                           8.0;
         from_gradient(gx, gy, nx, ny, nz);
       }},
      {"8-bit partial derivatives (deformable-terrain paper)",
       [](const Grid& g, int64_t x, int64_t y, double& nx, double& ny, double& nz) {
         auto q8 = [](double d) { return std::round(std::clamp(d, -1.0, 1.0) * 127.0) / 127.0; };
         from_gradient(q8((g.at(x + 1, y) - g.at(x - 1, y)) / 2.0),
                       q8((g.at(x, y + 1) - g.at(x, y - 1)) / 2.0), nx, ny, nz);
       }},
  };
}

struct AngleStats {
  double mean = 0, p99 = 0, max = 0;
};

AngleStats angles(const Method& m, const Grid& g, const Sines& s) {
  std::vector<double> a;
  a.reserve(size_t(g.n * g.n));
  double sum = 0;
  for (int64_t y = 2; y < g.n - 2; ++y) {
    for (int64_t x = 2; x < g.n - 2; ++x) {
      double nx = 0, ny = 0, nz = 0, tx = 0, ty = 0, tz = 0, gx = 0, gy = 0;
      m.normal(g, x, y, nx, ny, nz);
      s.gradient(double(x), double(y), gx, gy);
      from_gradient(gx, gy, tx, ty, tz);
      const double c = std::clamp(nx * tx + ny * ty + nz * tz, -1.0, 1.0);
      const double deg = std::acos(c) * 180.0 / M_PI;
      a.push_back(deg);
      sum += deg;
    }
  }
  std::sort(a.begin(), a.end());
  return {sum / double(a.size()), a[size_t(0.99 * double(a.size() - 1))], a.back()};
}

int run_normals(const Context& ctx, Report& report) {
  const std::vector<double> slopes = ctx.quick ? std::vector<double>{15, 45, 85}
                                               : std::vector<double>{5, 15, 30, 40, 45, 50, 60, 70, 80, 85};
  const std::vector<double> wavelengths = {16, 64};
  const int64_t n = ctx.quick ? 96 : 256;
  const std::vector<Method> ms = methods();
  Table table("normals", {"wavelength (samples)", "steepest slope (deg)", "method", "angle error mean (deg)",
                          "p99 (deg)", "max (deg)", "p99 with 5 cm heights (deg)"});
  std::vector<Series> series;
  for (const Method& m : ms) series.push_back({m.name, {}});
  for (double wl : wavelengths) {
    for (double slope : slopes) {
      const Sines s(wl, slope);
      const Grid exact = sample(s, n, 0.0), quantized = sample(s, n, 0.05);
      for (size_t k = 0; k < ms.size(); ++k) {
        const AngleStats e = angles(ms[k], exact, s), q = angles(ms[k], quantized, s);
        table.add_row({fmt(wl, 0), fmt(slope, 0), ms[k].name, fmt(e.mean, 3), fmt(e.p99, 3), fmt(e.max, 3),
                       fmt(q.p99, 3)});
        if (wl == 16) series[k].points.push_back({slope, std::max(e.max, 1e-4)});
      }
      std::printf("  wavelength %.0f, slope %.0f: done\n", wl, slope);
    }
  }

  // Cost: every interior texel of a 1024^2 grid, one core.
  const int64_t cn = ctx.quick ? 256 : 1024;
  const Sines s(64, 45);
  const Grid g = sample(s, cn, 0.0);
  Table cost("normals_cost", {"method", "ns per texel (median)", "spread"});
  for (const Method& m : ms) {
    volatile double sink = 0;
    const Timing t = measure(ctx, [&] {
      double acc = 0;
      for (int64_t y = 2; y < cn - 2; ++y)
        for (int64_t x = 2; x < cn - 2; ++x) {
          double nx = 0, ny = 0, nz = 0;
          m.normal(g, x, y, nx, ny, nz);
          acc += nx + ny + nz;
        }
      sink = sink + acc;
    });
    const double texels = double((cn - 4) * (cn - 4));
    cost.add_row({m.name, fmt(t.median_s / texels * 1e9, 2), t.spread()});
  }
  {
    // Loam's own FD4 path: the packed normal map of a World's tiles (protocol/normal_map.h).
    WorldParams p;
    p.tiles_x = int32_t(cn / kTileSize), p.tiles_y = int32_t(cn / kTileSize);
    std::vector<uint16_t> hs(size_t(cn * cn));
    for (size_t i = 0; i < hs.size(); ++i) hs[i] = uint16_t(32768 + 2000 * g.h[i]);
    const World world = std::move(World::from_samples(p, hs).value());
    const RectI rect = p.sample_rect();
    const Timing t = measure(ctx, [&] {
      volatile size_t k = generate_normal_map(world, rect).size();
      (void)k;
    });
    cost.add_row({"FD4 packed, generate_normal_map over a World (Loam's CPU path)",
                  fmt(t.median_s / double(rect.area()) * 1e9, 2), t.spread()});
  }
  report.paragraph(
      "Surfaces h = A sin(kx) sin(ky) sampled at 1 m, A k = tan(steepest slope), " + std::to_string(n) +
      "^2 samples "
      "(the two outermost rows and columns left out, where the stencils would need one-sided forms). The "
      "error is the angle between a method's unit normal and the analytic one at each sample. The 8-bit "
      "format stores each central-difference slope as round(127 clamp(s, -1, 1)): steeper than 45 degrees "
      "along an axis it saturates, and its error grows with the slope from there. Loam's packed normal is "
      "FD4 quantized to two signed 16-bit components (protocol/normal_map.h).");
  report.table(std::move(table));
  report.plot({"normals_error.png",
               "Largest angle error against the steepest slope, 16 samples per wavelength, exact heights",
               "steepest slope (degrees)",
               "max angle error (degrees)",
               false,
               true,
               series,
               {}});
  report.paragraph(
      "Cost per texel on the CPU, one core. The first rows are the stencils as written in this "
      "suite (through std::function, FD4 through protocol/surface.h's generic fd4_derivative), which "
      "compares their arithmetic; the last row is Loam's production CPU path, the packed FD4 normal "
      "map of a World's tiles. Clients compute normals on the GPU (gpu/normal_pass.h).");
  report.table(std::move(cost));
  return 0;
}

}  // namespace

LOAM_BENCH_SUITE(normals,
                 "normals: FD2, FD4, Horn and 8-bit slopes against analytic surfaces up to 85 degrees",
                 run_normals);

}  // namespace loam::bench
