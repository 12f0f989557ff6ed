#include "protocol/stamps/stamp_at_mip.h"

#include <algorithm>

#include "protocol/stamps/stamp_fast.h"
#include "protocol/world.h"

namespace loam {

FootprintContact footprint_contact_of(const BakedStamp& b, const World& world) {
  BakedStamp copy = b;
  footprint_contact_fast(copy, world);
  return {copy.has_contact, copy.contact_q8};
}

void set_contact(BakedStamp& b, const FootprintContact& c) {
  b.has_contact = c.touches;
  b.contact_q8 = c.touches ? c.height_q8 : 0;
}

RectI apply_to_coarse_tile(const BakedStamp& b, const WorldParams& world, const TileCoord& c,
                           std::span<uint16_t> tile) {
  if (!is_per_sample(b.q.kind) || b.q.layer != Layer::kCoarse || c.layer != Layer::kCoarse ||
      tile.size() != size_t(kTileSamples))
    return {};
  const RectI world_samples = world.sample_rect();
  const RectI own = tile_rect(c.tx, c.ty);
  const RectI part = mip_samples_reaching(world, c.mip, b.rect).intersect(own);
  if (part.empty()) return {};
  const int64_t step = int64_t(1) << c.mip;
  RectI changed;
  for (int64_t j = part.y0; j < part.y1; ++j) {
    const int64_t gy = std::clamp(j * step, world_samples.y0, world_samples.y1 - 1);
    uint16_t* row = tile.data() + size_t((j - own.y0) * kTileSize - own.x0);
    for (int64_t i = part.x0; i < part.x1; ++i) {
      const int64_t gx = std::clamp(i * step, world_samples.x0, world_samples.x1 - 1);
      const int32_t old = row[i];
      const int32_t now = stamp_sample(b, gx, gy, old);
      if (now != old) {
        row[i] = uint16_t(now);
        changed = changed.unite({i, j, i + 1, j + 1});
      }
    }
  }
  return changed.empty() ? RectI{} : changed.translated(-own.x0, -own.y0);
}

}  // namespace loam
