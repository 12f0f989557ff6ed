// Small worlds on a refined base for tests: a random coarse source refined 2^levels times, so
// untouched tiles are the base's, every mip differs from a fill, and an edit is a real change.
#pragma once

#include <cstdint>
#include <memory>

#include "protocol/base/tile_base.h"
#include "protocol/geometry.h"

namespace loam::test {

struct SmallRefinedSpec {
  int32_t source_w = 9, source_h = 5;  // coarse source samples
  int32_t levels = 6;                  // refined 2^levels times
  uint32_t source_seed = 5, seed = 3;  // the source's heights, the refinement's detail
  int32_t amplitude = 300;             // level l's detail amplitude is amplitude << l
  int32_t tiles_x = 2, tiles_y = 1;    // the world, at 1 m and 1/32 m a height unit
};

struct SmallRefined {
  WorldParams params;
  std::shared_ptr<const RefinedTileBase> base;  // null if the spec does not refine
};

SmallRefined small_refined(const SmallRefinedSpec& spec = {});

}  // namespace loam::test
