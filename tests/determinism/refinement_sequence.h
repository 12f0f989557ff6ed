// The golden refinement: a fixed synthetic source (integer hash, no libm) with strong
// relief, refined with non-zero amplitudes at every level, over tiles at every mip including
// negative positions and the source edge. Its hash pins the subdivision, the displacement
// hash and the roughness arithmetic: the GCC unit tests and the clang-built check in CI
// (tests/determinism/golden_check.cpp) must both reproduce it. No GoogleTest here.
#pragma once

#include <cstdint>

namespace loam::determinism {

inline constexpr uint64_t kGoldenRefinementHash = 0x14fba7c279947702ull;

// XXH3 chain of the tile hashes (hash_coarse_tile) in a fixed order.
uint64_t golden_refinement_hash();

}  // namespace loam::determinism
