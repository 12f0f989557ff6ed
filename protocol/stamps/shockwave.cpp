#include "protocol/stamps/shockwave.h"

#include <algorithm>

#include "protocol/stamps/stamp_kernel.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/world.h"
#include "protocol/world_layers.h"

namespace loam {

namespace {
constexpr int64_t kWaveLimit = int64_t(1) << 30;
}

WaveField::WaveField(int64_t w, int64_t h)
    : width(w), height(h), cur(size_t((w + 2) * (h + 2)), 0), prev(size_t((w + 2) * (h + 2)), 0) {}

void wave_step(WaveField& f, const RectI& active, int32_t nu2_q16, int32_t damping_q16) {
  const RectI a = active.intersect(RectI{0, 0, f.width, f.height});
  const int64_t stride = f.width + 2;
  for (int64_t y = a.y0; y < a.y1; ++y) {
    const int32_t* c = f.cur.data() + (y + 1) * stride + 1;
    int32_t* p = f.prev.data() + (y + 1) * stride + 1;
    for (int64_t x = a.x0; x < a.x1; ++x) {
      const int64_t w = c[x];
      const int64_t lap = int64_t(c[x - 1]) + c[x + 1] + c[x - stride] + c[x + stride] - 4 * w;
      const int64_t v = w - p[x];
      // >> on negative int64 is floor division by 2^16 (C++20): round half up, the same
      // on every platform.
      const int64_t next =
          w + v - ((v * damping_q16 + (1 << 15)) >> 16) + ((lap * nu2_q16 + (1 << 15)) >> 16);
      p[x] = int32_t(std::clamp(next, -kWaveLimit, kWaveLimit));  // prev becomes next
    }
  }
  std::swap(f.cur, f.prev);
}

namespace {
RectI pulse_rect(const QuantizedStamp& q, const BakedStamp& b) {
  return {ceil_div(q.center_x - b.support_q8, 256), ceil_div(q.center_y - b.support_q8, 256),
          floor_div(q.center_x + b.support_q8, 256) + 1, floor_div(q.center_y + b.support_q8, 256) + 1};
}
}  // namespace

RectI shockwave_box(const BakedStamp& b, const RectI& world_rect) {
  const int64_t total = int64_t(b.q.steps) * shockwave_substeps(b.q.speed);
  const RectI pulse = pulse_rect(b.q, b);
  return RectI{pulse.x0 - total, pulse.y0 - total, pulse.x1 + total, pulse.y1 + total}.intersect(world_rect);
}

Result<RectI> apply_shockwave(World& world, const QuantizedStamp& q) {
  auto baked = bake_stamp(q, world.params());  // the Gaussian pulse
  LOAM_TRY(baked);
  const BakedStamp& b = baked.value();
  const int32_t sub = shockwave_substeps(q.speed);
  const int32_t nu2 = shockwave_nu2_q16(q.speed, sub);
  const int64_t total = int64_t(q.steps) * sub;
  const RectI pulse = pulse_rect(q, b);
  const RectI box = shockwave_box(b, layer_sample_rect(world.params(), q.layer));
  if (box.empty()) return RectI{};
  WaveField f(box.width(), box.height());
  for (int64_t y = box.y0; y < box.y1; ++y) {
    for (int64_t x = box.x0; x < box.x1; ++x) {
      const int32_t u = radial_u_q16(b, x, y);
      if (u < 0) continue;
      const int32_t w0 = table_lookup(b.table, u);
      f.at(f.cur, x - box.x0, y - box.y0) = w0;
      f.at(f.prev, x - box.x0, y - box.y0) = w0;  // at rest
    }
  }
  const RectI local_pulse = pulse.translated(-box.x0, -box.y0);
  for (int64_t n = 1; n <= total; ++n) {
    wave_step(f, RectI{local_pulse.x0 - n, local_pulse.y0 - n, local_pulse.x1 + n, local_pulse.y1 + n}, nu2,
              q.damping);
  }
  // Apply saturate(old + round(w)) tile by tile (the layer's row chosen once, outside the loops).
  return visit_layer(q.layer, [&](auto row) {
    using R = decltype(row);
    RectI touched;
    const RectI tiles = tiles_overlapping(box);
    for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
      for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
        const RectI part = box.intersect(tile_rect(int32_t(tx), int32_t(ty)));
        RectI changed;
        for (int64_t y = part.y0; y < part.y1; ++y) {
          for (int64_t x = part.x0; x < part.x1; ++x) {
            const int32_t delta = round_q8(f.get(x - box.x0, y - box.y0));
            if (delta == 0) continue;
            const int32_t old = int32_t(LayerOps<R>::sample(world, x, y));
            const int32_t nv = std::clamp(old + delta, R::kMin, R::kMax);
            if (nv == old) continue;
            // The tile is only written (a detail tile: stored) where a sample changes.
            const size_t i = size_t((y - ty * kTileSize) * kTileSize + (x - tx * kTileSize));
            LayerOps<R>::tile_mut(world, int32_t(tx), int32_t(ty))[i] = typename R::Sample(nv);
            changed = changed.unite(RectI{x, y, x + 1, y + 1});
          }
        }
        if (!changed.empty()) {
          world.mark_dirty(q.layer, changed);
          touched = touched.unite(changed);
        }
      }
    }
    return touched;
  });
}

}  // namespace loam
