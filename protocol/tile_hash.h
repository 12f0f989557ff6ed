// Content hashes of tiles and worlds (xxHash XXH3-64 over little-endian sample bytes).
//
// These hashes are part of the protocol: clients compare them with the server's TileHashes,
// and replay compares world hashes. docs/world.md states the exact byte layout.
#pragma once

#include <cstdint>
#include <span>

namespace loam {

uint64_t hash_coarse_tile(std::span<const uint16_t> samples);
uint64_t hash_detail_tile(std::span<const int8_t> samples);
// Hash of an absent (all-zero) detail tile.
uint64_t zero_detail_tile_hash();

// Incremental world hash: feed (layer, tx, ty, tile hash) in canonical order.
class WorldHasher {
 public:
  WorldHasher();
  ~WorldHasher();
  WorldHasher(const WorldHasher&) = delete;
  WorldHasher& operator=(const WorldHasher&) = delete;
  void add(uint8_t layer, int32_t tx, int32_t ty, uint64_t tile_hash);
  uint64_t finish() const;

 private:
  void* state_;
};

}  // namespace loam
