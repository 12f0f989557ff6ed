#include "tests/determinism/refinement_sequence.h"

#include <cassert>
#include <vector>

#include "protocol/base/refinement.h"
#include "protocol/tile_hash.h"

namespace loam::determinism {

uint64_t golden_refinement_hash() {
  constexpr int32_t w = 13, h = 9;
  std::vector<int32_t> source(size_t(w * h));
  uint32_t s = 12345;
  for (auto& v : source) {
    s = s * 1664525u + 1013904223u;
    v = int32_t(s >> 16);  // 0..65535: relief at its largest
  }
  RefinementParams p;
  p.levels = 6;
  p.seed = 0x0123456789abcdefull;
  for (int32_t l = 0; l < p.levels; ++l) p.amplitude[size_t(l)] = 500 << l;
  p.roughness_base = 128;
  p.roughness_gain = 3;
  p.roughness_max = 2048;
  auto base = RefinedBase::create(w, h, source, p);
  assert(base.ok());
  WorldHasher hasher;
  std::vector<uint16_t> tile(static_cast<size_t>(kTileSamples));
  for (int32_t mip = 0; mip < 9; ++mip) {
    for (const auto& [tx, ty] : {std::pair{0, 0}, std::pair{-1, 0}, std::pair{2, 1}, std::pair{0, -1}}) {
      base->generate_tile(mip, tx, ty, tile);
      hasher.add(uint8_t(mip), tx, ty, hash_coarse_tile(tile));
    }
  }
  return hasher.finish();
}

}  // namespace loam::determinism
