// Two worlds of the same parameters compared tile by tile, for tests: every coarse tile of
// every mip (samples and hash, and the version when asked) and every detail tile. Names the
// first difference, so a failing test says where the worlds part.
#pragma once

#include <optional>
#include <string>

#include "protocol/world.h"

namespace loam::test {

struct TileComparison {
  bool versions = true;  // versions must agree too (not across differently built worlds)
  bool detail = true;    // the detail layer too
};

// "mip M tile X,Y: samples|hash|version differ" (or the detail tile's), or nullopt when every
// compared tile agrees.
std::optional<std::string> first_tile_difference(const World& a, const World& b, TileComparison what = {});

// Samples of `layer` (mip 0, the whole layer) that differ between the two worlds; read row by
// row, so a wide world's layer never sits in memory twice.
int64_t sample_mismatches(const World& a, const World& b, Layer layer);

}  // namespace loam::test
