// Content hashes of tiles and worlds (xxHash XXH3-64 over little-endian sample bytes).
//
// These hashes are part of the protocol: clients compare them with the server's TileHashes,
// and replay compares world hashes. docs/world.md states the exact byte layout.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>

namespace loam {

// XXH3-64 of a tile's sample bytes, little-endian: every layer's tiles hash so, whatever their
// sample type.
uint64_t hash_sample_bytes(const void* data, size_t bytes);
template <class T>
requires std::is_integral_v<T> uint64_t hash_tile(std::span<const T> samples) {
  return hash_sample_bytes(samples.data(), samples.size_bytes());
}

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
