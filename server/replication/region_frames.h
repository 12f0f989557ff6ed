// Encode once: the RegionUpdate frames of one tile region, keyed by what they contain (tile,
// the base version a patch goes over, the new version, the rect), cached so that every
// client needing the same bytes costs one encode. A join storm of N clients subscribing to
// the same tiles encodes each tile once; N clients missing the same shockwave patch, once.
//
// A patch over a version the tile history can rebuild is coded as a delta against the samples
// the client holds (kDelta: a stamp's patch costs a few hundred bytes, not a few KB); anything
// else leaves in the fast mode at once. A whole tile asked for again (a join storm, a popular
// coarse tile) is re-encoded in the best mode off the tick thread and replaces the fast frames
// in the cache when smaller.
//
// The cache is bounded in bytes (least recently used entries go first) and counts encodes,
// hits, deltas and upgrades for the server's Stats. Encoding reads the World; the frames are
// immutable and shared. Single-threaded apart from the best-mode worker: the replication core
// owns it.
#pragma once

#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/result.h"
#include "protocol/world.h"
#include "server/replication/background_encoder.h"
#include "server/replication/region_key.h"
#include "server/replication/tile_history.h"

namespace loam::server {

// One encoded frame, shared by every client it goes to.
using FramePtr = std::shared_ptr<const std::vector<uint8_t>>;
using Frames = std::vector<FramePtr>;

struct RegionFrameCounters {
  uint64_t encodes = 0;           // regions encoded
  uint64_t delta_encodes = 0;     // of which patches coded against the held samples (kDelta)
  uint64_t hits = 0;              // regions served from the cache
  uint64_t evictions = 0;         // entries dropped to stay under the byte bound
  uint64_t bytes_held = 0;        // frames held now
  uint64_t best_upgrades = 0;     // whole tiles re-encoded in the best mode, and adopted
  uint64_t best_bytes_saved = 0;  // bytes those upgrades took off each later send
};

class RegionFrames {
 public:
  // `best_after_uses`: a whole tile's frames used this many times (the encode included) are
  // re-encoded in the best mode (0: never). At most `best_queue` upgrades wait at once.
  explicit RegionFrames(uint64_t max_bytes, uint32_t best_after_uses = 2, size_t best_queue = 64)
      : max_bytes_(max_bytes), best_after_uses_(best_after_uses), best_(best_queue) {}

  // The frames of tile c at its current version in `world`: a patch of `rect` over `base`
  // when base is set (a delta when `history` can rebuild the samples at `base`), else the
  // whole tile. `encoded` (optional) tells whether this call encoded.
  Result<Frames> get(const World& world, const TileHistory* history, const TileCoord& c,
                     std::optional<uint64_t> base, const RectI& rect, bool* encoded = nullptr);
  // The same frames when the cache holds them (no encode); empty otherwise.
  Frames cached(const World& world, const TileCoord& c, std::optional<uint64_t> base, const RectI& rect);
  // Puts the best-mode payloads finished since the last call in place of the fast frames of
  // entries still cached (the same samples: a client may get either). Once per tick.
  void adopt_best();
  // Waits for every queued best-mode encode, then adopts them (tests, benchmarks).
  void finish_best();
  const RegionFrameCounters& counters() const { return counters_; }

 private:
  struct Entry {
    Frames frames;
    uint64_t bytes = 0;
    std::list<RegionKey>::iterator lru;
    uint32_t uses = 1;
    bool best = false;  // queued for, or already in, the best mode
  };
  void use(const World& world, const RegionKey& key, Entry& e);

  uint64_t max_bytes_;
  uint32_t best_after_uses_;
  std::map<RegionKey, Entry> entries_;
  std::list<RegionKey> lru_;  // most recently used first
  RegionFrameCounters counters_;
  BackgroundEncoder best_;
};

// Encodes the RegionUpdate frames of a tile region (no cache): the samples of `rect` of tile c
// at its current version, as a patch over `base` or the whole tile. A patch is a delta against
// the samples at `base` when `history` can rebuild them (`delta` then says so), else fast-coded.
Result<Frames> encode_region_frames(const World& world, const TileHistory* history, const TileCoord& c,
                                    std::optional<uint64_t> base, const RectI& rect, bool* delta = nullptr);

// The RegionUpdate frames carrying an encoded payload of the region `key` names.
Result<Frames> region_frames_of(const RegionKey& key, std::span<const uint8_t> payload);

}  // namespace loam::server
