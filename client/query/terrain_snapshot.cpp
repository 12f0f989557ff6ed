#include "client/query/terrain_snapshot.h"

#include <algorithm>
#include <cstdlib>

namespace loam::query {

std::shared_ptr<const CoarseTile> make_coarse_tile(std::span<const uint16_t> samples) {
  auto t = std::make_shared<CoarseTile>();
  t->samples.assign(samples.begin(), samples.end());
  t->samples.resize(kTileSamples, 0);
  for (int32_t by = 0; by < kBlocksPerTile; ++by) {
    for (int32_t bx = 0; bx < kBlocksPerTile; ++bx) {
      uint16_t lo = 0xFFFF, hi = 0;
      for (int32_t y = by * kBlockSamples; y < (by + 1) * kBlockSamples; ++y) {
        const uint16_t* row = t->samples.data() + size_t(y) * kTileSize + size_t(bx) * kBlockSamples;
        const auto [mn, mx] = std::minmax_element(row, row + kBlockSamples);
        lo = std::min(lo, *mn);
        hi = std::max(hi, *mx);
      }
      t->block_min[size_t(by * kBlocksPerTile + bx)] = lo;
      t->block_max[size_t(by * kBlocksPerTile + bx)] = hi;
    }
  }
  return t;
}

std::shared_ptr<const DetailTile> make_detail_tile(std::span<const int8_t> samples) {
  auto t = std::make_shared<DetailTile>();
  t->samples.assign(samples.begin(), samples.end());
  t->samples.resize(kTileSamples, 0);
  for (const int8_t s : t->samples) t->largest_offset = std::max(t->largest_offset, std::abs(int32_t(s)));
  return t;
}

TerrainSnapshot::TerrainSnapshot(const WorldParams& params, CoarseMap coarse, DetailMap detail, Stamp stamp)
    : params_(params),
      world_(params.sample_rect()),
      coarse_(std::move(coarse)),
      detail_(std::move(detail)),
      stamp_(stamp) {
  int32_t largest = 0;
  for (const auto& [k, t] : detail_) largest = std::max(largest, t->largest_offset);
  detail_extent_m_ = params_.detail_meters(int8_t(std::min(largest, 127)));
}

size_t TerrainSnapshot::bytes() const {
  return coarse_.size() * (kTileSamples * sizeof(uint16_t) + sizeof(CoarseTile)) +
         detail_.size() * (kTileSamples + sizeof(DetailTile));
}

}  // namespace loam::query
