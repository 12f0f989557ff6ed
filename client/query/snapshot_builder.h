// SnapshotBuilder: makes each new TerrainSnapshot from the display's samples on the thread that
// owns the display (the network thread), copying only what changed: tiles newly held, tiles
// under a changed rect; tiles no longer held are dropped, the rest are shared with the last
// snapshot. Pure logic over a World (the display's CPU copy): no sockets, no GL.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "client/query/terrain_snapshot.h"
#include "protocol/world.h"

namespace loam::query {

struct ChangedRect {
  Layer layer = Layer::kCoarse;
  RectI rect;  // the layer's global mip-0 samples
};

class SnapshotBuilder {
 public:
  explicit SnapshotBuilder(const WorldParams& params) : params_(params) {}

  // `held`: the mip-0 tiles (either layer) whose samples `display` holds; `changed`: rects of
  // `display` changed since the last build. Tiles of other mips in `held` are ignored.
  std::shared_ptr<const TerrainSnapshot> build(const World& display, std::span<const TileCoord> held,
                                               std::span<const ChangedRect> changed, uint64_t event_seq,
                                               size_t own_stamps_shown);
  // Tiles copied by all builds so far (what publishing cost).
  uint64_t tiles_copied() const { return tiles_copied_; }

 private:
  WorldParams params_;
  TerrainSnapshot::CoarseMap coarse_;
  TerrainSnapshot::DetailMap detail_;
  uint64_t generation_ = 0;
  uint64_t tiles_copied_ = 0;
};

}  // namespace loam::query
