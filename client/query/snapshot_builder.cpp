#include "client/query/snapshot_builder.h"

#include <unordered_set>

namespace loam::query {

std::shared_ptr<const TerrainSnapshot> SnapshotBuilder::build(const World& display,
                                                              std::span<const TileCoord> held,
                                                              std::span<const ChangedRect> changed,
                                                              uint64_t event_seq, size_t own_stamps_shown) {
  // Tiles under a changed rect, per layer.
  std::unordered_set<uint64_t> stale[kLayerCount];
  for (const ChangedRect& c : changed) {
    if (c.rect.empty()) continue;
    const RectI tiles = tiles_overlapping(c.rect);
    for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
      for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx)
        stale[size_t(c.layer)].insert(TerrainSnapshot::key(tx, ty));
    }
  }
  TerrainSnapshot::CoarseMap coarse;
  TerrainSnapshot::DetailMap detail;
  for (const TileCoord& c : held) {
    if (c.mip != 0) continue;
    const uint64_t k = TerrainSnapshot::key(c.tx, c.ty);
    if (c.layer == Layer::kCoarse) {
      const auto it = coarse_.find(k);
      if (it != coarse_.end() && !stale[size_t(Layer::kCoarse)].count(k)) {
        coarse.emplace(k, it->second);
      } else {
        coarse.emplace(k, make_coarse_tile(display.coarse_tile(0, c.tx, c.ty)));
        ++tiles_copied_;
      }
    } else {
      const auto it = detail_.find(k);
      if (it != detail_.end() && !stale[size_t(Layer::kDetail)].count(k)) {
        detail.emplace(k, it->second);
      } else if (const auto samples = display.detail_tile(c.tx, c.ty); !samples.empty()) {
        detail.emplace(k, make_detail_tile(samples));
        ++tiles_copied_;
      }
    }
  }
  coarse_ = coarse;
  detail_ = detail;
  return std::make_shared<const TerrainSnapshot>(
      params_, std::move(coarse), std::move(detail),
      TerrainSnapshot::Stamp{++generation_, event_seq, own_stamps_shown});
}

}  // namespace loam::query
