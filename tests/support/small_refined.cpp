#include "tests/support/small_refined.h"

#include <vector>

namespace loam::test {

SmallRefined small_refined(const SmallRefinedSpec& spec) {
  std::vector<int32_t> source(size_t(spec.source_w) * size_t(spec.source_h));
  uint32_t s = spec.source_seed;
  for (auto& v : source) {
    s = s * 1664525u + 1013904223u;
    v = 20000 + int32_t(s >> 20);
  }
  RefinementParams rp;
  rp.levels = spec.levels;
  rp.seed = spec.seed;
  for (int32_t l = 0; l < spec.levels; ++l) rp.amplitude[size_t(l)] = spec.amplitude << l;
  rp.roughness_gain = 2;
  SmallRefined out;
  out.params.meters_per_sample = 1.0;
  out.params.meters_per_unit = 1.0 / 32.0;
  out.params.tiles_x = spec.tiles_x;
  out.params.tiles_y = spec.tiles_y;
  auto refined = RefinedBase::create(spec.source_w, spec.source_h, source, rp);
  if (!refined) return out;
  auto base = RefinedTileBase::create(std::move(*refined), out.params);
  if (base) out.base = *base;
  return out;
}

}  // namespace loam::test
