// What an encoded tile region contains, as the key of the encode-once cache (region_frames.h):
// the tile, the version a patch goes over, the new version and the rect.
#pragma once

#include <compare>
#include <cstdint>
#include <tuple>

#include "protocol/geometry.h"

namespace loam::server {

struct RegionKey {
  TileCoord tile;
  uint64_t base = 0;  // patch: the version it goes over; whole tile: 0
  uint64_t version = 0;
  RectI rect;
  bool patch = false;
  friend auto operator<=>(const RegionKey& a, const RegionKey& b) {
    return std::tie(a.tile, a.base, a.version, a.rect.x0, a.rect.y0, a.rect.x1, a.rect.y1, a.patch) <=>
           std::tie(b.tile, b.base, b.version, b.rect.x0, b.rect.y0, b.rect.x1, b.rect.y1, b.patch);
  }
  friend bool operator==(const RegionKey&, const RegionKey&) = default;
};

}  // namespace loam::server
