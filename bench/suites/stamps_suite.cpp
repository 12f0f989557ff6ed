// Suite `stamps`: time per stamp of the CPU stamp path (apply_stamp: the fast kernel) against
// radius, texels per second, and the fraction of the memory-bandwidth floor reached (a stamp
// reads and writes each sample of its rect once, like a memcpy of 2 bytes per sample; target
// >= 0.5 from 1024^2 up). The scalar reference (apply_stamp_reference) is timed beside it at
// a few radii, and shockwave (not a per-sample kind, no fast path) is reported as it is.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "bench/harness.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/world.h"

namespace loam::bench {
namespace {

int run_stamps(const Context& ctx, Report& report) {
  WorldParams p;
  p.meters_per_sample = 1.0;
  p.meters_per_unit = 1.0 / 64.0;
  p.tiles_x = ctx.quick ? 4 : 12;
  p.tiles_y = ctx.quick ? 4 : 12;
  World world(p, 32768);
  StampLimits limits;
  const double side = double(p.tiles_x) * kTileSize;
  std::vector<double> radii = {2, 8, 32, 128, 512, 1024};
  if (ctx.quick) radii = {2, 32, 256};
  Table table("stamps", {"kind", "radius (samples)", "rect", "ms / stamp (median)", "spread", "Mtexels/s",
                         "floor ms", "fraction of floor"});
  std::vector<Series> series;
  struct Variant {
    StampKind kind;
    bool reference;
  };
  const std::vector<Variant> variants = {{StampKind::kGaussian, false},
                                         {StampKind::kCrater, false},
                                         {StampKind::kFlatten, false},
                                         {StampKind::kGaussian, true},
                                         {StampKind::kShockwave, false}};
  for (const Variant& variant : variants) {
    const StampKind kind = variant.kind;
    const std::string label = std::string(to_string(kind)) + (variant.reference ? " (scalar reference)" : "");
    Series s{label, {}};
    std::vector<double> kind_radii = radii;
    if (variant.reference)
      kind_radii = ctx.quick ? std::vector<double>{32} : std::vector<double>{32, 128, 512};
    if (kind == StampKind::kShockwave)
      kind_radii = ctx.quick ? std::vector<double>{8} : std::vector<double>{8, 32};
    for (const double r : kind_radii) {
      StampParams sp;
      sp.kind = kind;
      sp.center_x = side / 2 + 0.3;
      sp.center_y = side / 2 - 0.2;
      sp.radius = r;
      sp.intensity = kind == StampKind::kFlatten ? 0.5 : 2.0;
      if (kind == StampKind::kFlatten) sp.target = 500.0;  // the only kind here with a target
      sp.shape = 0.5;
      sp.steps = 64;
      sp.damping = 0.05;
      auto add = validate_stamp(sp, p, limits);
      sp.blend = BlendMode::kSubtract;
      if (kind == StampKind::kFlatten) sp.blend = BlendMode::kAdd;
      if (kind == StampKind::kShockwave) {  // add-only kind: undo with the opposite pulse
        sp.blend = BlendMode::kAdd;
        sp.intensity = -sp.intensity;
      }
      auto sub = validate_stamp(sp, p, limits);
      if (!add.ok() || !sub.ok()) {
        std::fprintf(stderr, "stamps: %s\n", (add.ok() ? sub.error() : add.error()).describe().c_str());
        return 1;
      }
      bool flip = false;
      const Timing t = measure(ctx, [&] {
        const QuantizedStamp& q = flip ? sub.value() : add.value();
        (void)(variant.reference ? apply_stamp_reference(world, q) : apply_stamp(world, q));
        flip = !flip;
      });
      world.commit(1);
      // Shockwave's box grows one cell per step.
      const double d = 2.0 * std::ceil(r) + 1.0 + (kind == StampKind::kShockwave ? 2.0 * sp.steps : 0.0);
      const double texels = d * d;
      const double floor_s = texels * 2.0 / (ctx.memcpy_gbps * 1e9);
      char buf[8][64];
      std::snprintf(buf[0], 64, "%.0f", r);
      std::snprintf(buf[1], 64, "%.0f^2", d);
      std::snprintf(buf[2], 64, "%.4f", t.median_s * 1e3);
      std::snprintf(buf[3], 64, "%.1f", texels / t.median_s / 1e6);
      std::snprintf(buf[4], 64, "%.4f", floor_s * 1e3);
      std::snprintf(buf[5], 64, "%.3f", floor_s / t.median_s);
      table.add_row({label, buf[0], buf[1], buf[2], t.spread(), buf[3], buf[4], buf[5]});
      s.points.push_back({r, texels / t.median_s / 1e6});
    }
    series.push_back(s);
  }
  report.paragraph("CPU stamps (`apply_stamp`: the fast kernel, AVX2 where the CPU has it, one core) on a " +
                   std::to_string(int(side)) +
                   "^2 coarse world; add/subtract alternate so the terrain stays put. The floor is the "
                   "memcpy time of 2 bytes per texel of the stamp's rect at the measured memcpy bandwidth. "
                   "`scalar reference` rows time `apply_stamp_reference` (stamp_sample on every sample), "
                   "which defines the integers the fast kernel reproduces. Shockwave (64 steps, damping "
                   "0.05; its rect grows one cell per step) has no fast path.");
  report.table(table);
  report.plot(
      Plot{"stamps_texels.png", "Stamp throughput", "radius (samples)", "Mtexels/s", true, true, series, {}});
  return 0;
}

}  // namespace

LOAM_BENCH_SUITE(stamps, "stamp CPU reference: time per stamp and texels/s against radius", run_stamps);

}  // namespace loam::bench
