// Suite `stamps`: time per stamp of the CPU stamp path (apply_stamp: the fast kernel) against
// radius, texels per second, and the fraction of the stamp's own memory floor reached. The
// floor is a copy of the stamp rect's own bytes, read and written in place in the world's
// tiles as the stamp reads and writes them, timed right after the stamp at the same cache
// state (targets: >= 0.5 of it from 1025^2 up, and <= 2 us per stamp up to radius 8, for
// gaussian, crater, flatten and footprint). The scalar reference (apply_stamp_reference) is
// timed beside it at a few radii, and shockwave (not a per-sample kind, no fast path) is
// reported as it is.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "bench/harness.h"
#include "protocol/geometry.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/world.h"

namespace loam::bench {
namespace {

// The stamp's memory floor: every row of `rect` (mip-0 coarse samples), tile by tile, copied
// out to a row buffer and back in place: each byte of the rect read once and written once,
// the traffic a stamp's read-modify-write cannot go below.
void copy_rect_in_place(World& world, const RectI& rect, std::vector<uint16_t>& row_buffer) {
  const RectI tiles = tiles_overlapping(rect);
  for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
    for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
      const RectI part = rect.intersect(tile_rect(int32_t(tx), int32_t(ty)));
      uint16_t* tile = world.coarse_tile_mut(int32_t(tx), int32_t(ty)).data();
      const size_t bytes = size_t(part.width()) * sizeof(uint16_t);
      for (int64_t y = part.y0; y < part.y1; ++y) {
        uint16_t* row = tile + (y - ty * kTileSize) * kTileSize + (part.x0 - tx * kTileSize);
        std::memcpy(row_buffer.data(), row, bytes);
        std::memcpy(row, row_buffer.data(), bytes);
      }
    }
  }
}

int run_stamps(const Context& ctx, Report& report) {
  WorldParams p;
  p.meters_per_sample = 1.0;
  p.meters_per_unit = 1.0 / 64.0;
  p.tiles_x = ctx.quick ? 4 : 12;
  p.tiles_y = ctx.quick ? 4 : 12;
  World world(p, 32768);
  StampLimits limits;
  const double side = double(p.tiles_x) * kTileSize;
  std::vector<double> radii = {2, 4, 8, 32, 128, 512, 1024};
  if (ctx.quick) radii = {2, 8, 256};
  Table table("stamps", {"kind", "radius (samples)", "rect", "us / stamp (median)", "spread", "Mtexels/s",
                         "floor us", "fraction of floor", "target"});
  std::vector<Series> series;
  struct Variant {
    StampKind kind;
    bool reference;
  };
  const std::vector<Variant> variants = {{StampKind::kGaussian, false}, {StampKind::kCrater, false},
                                         {StampKind::kFlatten, false},  {StampKind::kFootprint, false},
                                         {StampKind::kGaussian, true},  {StampKind::kShockwave, false}};
  std::vector<uint16_t> row_buffer(kTileSize);
  int missed = 0;
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
      // Footprint has its own combination (min with its sole): each press sinks the foot by
      // its depth (2 units a press from 32768 never reaches the floor), so it has no opposite.
      sp.blend = BlendMode::kAdd;
      auto add = validate_stamp(sp, p, limits);
      if (kind != StampKind::kFlatten && kind != StampKind::kFootprint) sp.blend = BlendMode::kSubtract;
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
      // The floor over the same rect, right after, at the same cache state. Shockwave's box
      // grows one cell per step.
      const auto reach = stamp_reach(add.value(), p);
      RectI rect = reach.ok() ? reach.value() : RectI{};
      const double texels = double(rect.area());
      const Timing floor = measure(ctx, [&] { copy_rect_in_place(world, rect, row_buffer); });
      char buf[9][64];
      std::snprintf(buf[0], 64, "%.0f", r);
      std::snprintf(buf[1], 64, "%lldx%lld", static_cast<long long>(rect.width()),
                    static_cast<long long>(rect.height()));
      std::snprintf(buf[2], 64, "%.2f", t.median_s * 1e6);
      std::snprintf(buf[3], 64, "%.1f", texels / t.median_s / 1e6);
      std::snprintf(buf[4], 64, "%.2f", floor.median_s * 1e6);
      std::snprintf(buf[5], 64, "%.3f", floor.median_s / t.median_s);
      // The two targets, on the four per-sample kinds of the fast path.
      std::string target;
      const bool fast_kind = !variant.reference && kind != StampKind::kShockwave;
      if (fast_kind && r <= 8) {
        const bool met = t.median_s <= 2e-6;
        target = std::string("<= 2 us: ") + (met ? "met" : "missed");
        missed += met ? 0 : 1;
      } else if (fast_kind && rect.width() >= 1025) {
        const bool met = floor.median_s / t.median_s >= 0.5;
        target = std::string(">= 0.5 of floor: ") + (met ? "met" : "missed");
        missed += met ? 0 : 1;
      }
      table.add_row({label, buf[0], buf[1], buf[2], t.spread(), buf[3], buf[4], buf[5], target});
      s.points.push_back({r, texels / t.median_s / 1e6});
    }
    series.push_back(s);
  }
  report.paragraph(
      "CPU stamps (`apply_stamp`: the fast kernel, AVX2 where the CPU has it, one core) on a " +
      std::to_string(int(side)) +
      "^2 coarse world; add/subtract alternate so the terrain stays put (footprint, "
      "which has no opposite, sinks 2 units a press). The floor is the stamp rect's own bytes copied out "
      "of the world's tiles row by row and back in place: each byte read and written once, as "
      "the stamp does, timed right after it at the same cache state (the rect stays in cache "
      "where the stamp's does). For reference, one core copies " +
      fmt(ctx.memcpy_gbps, 2) +
      " GB/s between 64 MiB buffers in this run. `scalar reference` rows time "
      "`apply_stamp_reference` (stamp_sample on every sample), which defines the integers "
      "the fast kernel reproduces. Shockwave (64 steps, damping 0.05; its rect grows one cell "
      "per step) has no fast path. Targets: <= 2 us per stamp up to radius 8 and >= 0.5 of "
      "the floor from 1025^2 up, for gaussian, crater, flatten and footprint; " +
      std::to_string(missed) + " missed in this run.");
  report.table(table);
  report.plot(
      Plot{"stamps_texels.png", "Stamp throughput", "radius (samples)", "Mtexels/s", true, true, series, {}});
  return 0;
}

}  // namespace

LOAM_BENCH_SUITE(stamps, "stamp CPU reference: time per stamp and texels/s against radius", run_stamps);

}  // namespace loam::bench
