// Encode once: the RegionUpdate frames of one tile region, keyed by what they contain (tile,
// the base version a patch goes over, the new version, the rect), cached so that every
// client needing the same bytes costs one encode. A join storm of N clients subscribing to
// the same tiles encodes each tile once; N clients missing the same shockwave patch, once.
//
// The cache is bounded in bytes (least recently used entries go first) and counts encodes
// and hits for the server's Stats. Encoding reads the World; the frames are immutable and
// shared. Single-threaded: the replication core owns it.
#pragma once

#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <optional>
#include <tuple>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/result.h"
#include "protocol/world.h"

namespace loam::server {

// One encoded frame, shared by every client it goes to.
using FramePtr = std::shared_ptr<const std::vector<uint8_t>>;
using Frames = std::vector<FramePtr>;

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

struct RegionFrameCounters {
  uint64_t encodes = 0;     // regions encoded
  uint64_t hits = 0;        // regions served from the cache
  uint64_t evictions = 0;   // entries dropped to stay under the byte bound
  uint64_t bytes_held = 0;  // frames held now
};

class RegionFrames {
 public:
  explicit RegionFrames(uint64_t max_bytes) : max_bytes_(max_bytes) {}

  // The frames of tile c at its current version in `world`: a patch of `rect` over `base`
  // when base is set, else the whole tile. `encoded` (optional) tells whether this call encoded.
  Result<Frames> get(const World& world, const TileCoord& c, std::optional<uint64_t> base, const RectI& rect,
                     bool* encoded = nullptr);
  // The same frames when the cache holds them (no encode); empty otherwise.
  Frames cached(const World& world, const TileCoord& c, std::optional<uint64_t> base, const RectI& rect);
  const RegionFrameCounters& counters() const { return counters_; }

 private:
  struct Entry {
    Frames frames;
    uint64_t bytes = 0;
    std::list<RegionKey>::iterator lru;
  };
  uint64_t max_bytes_;
  std::map<RegionKey, Entry> entries_;
  std::list<RegionKey> lru_;  // most recently used first
  RegionFrameCounters counters_;
};

// Encodes the RegionUpdate frames of a tile region (no cache): the samples of `rect` of tile c
// at its current version, as a patch over `base` or the whole tile.
Result<Frames> encode_region_frames(const World& world, const TileCoord& c, std::optional<uint64_t> base,
                                    const RectI& rect);

}  // namespace loam::server
