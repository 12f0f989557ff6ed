#include "protocol/tile_hash.h"

#include <xxhash.h>

#include <bit>
#include <cstring>
#include <vector>

#include "protocol/geometry.h"

namespace loam {

// Sample bytes are hashed as stored in memory; the wire and hash format is little-endian.
static_assert(std::endian::native == std::endian::little,
              "Loam hashes samples in little-endian byte order; big-endian needs a byte swap");

uint64_t hash_sample_bytes(const void* data, size_t bytes) { return XXH3_64bits(data, bytes); }

uint64_t hash_coarse_tile(std::span<const uint16_t> samples) { return hash_tile(samples); }

uint64_t hash_detail_tile(std::span<const int8_t> samples) { return hash_tile(samples); }

uint64_t zero_detail_tile_hash() {
  static const uint64_t hash = [] {
    std::vector<int8_t> zeros(kTileSamples, 0);
    return hash_detail_tile(zeros);
  }();
  return hash;
}

WorldHasher::WorldHasher() : state_(XXH3_createState()) {
  XXH3_64bits_reset(static_cast<XXH3_state_t*>(state_));
}
WorldHasher::~WorldHasher() { XXH3_freeState(static_cast<XXH3_state_t*>(state_)); }

void WorldHasher::add(uint8_t layer, int32_t tx, int32_t ty, uint64_t tile_hash) {
  unsigned char record[17];
  record[0] = layer;
  std::memcpy(record + 1, &tx, 4);
  std::memcpy(record + 5, &ty, 4);
  std::memcpy(record + 9, &tile_hash, 8);
  XXH3_64bits_update(static_cast<XXH3_state_t*>(state_), record, sizeof record);
}

uint64_t WorldHasher::finish() const { return XXH3_64bits_digest(static_cast<XXH3_state_t*>(state_)); }

}  // namespace loam
