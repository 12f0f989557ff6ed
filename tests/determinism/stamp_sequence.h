// The golden stamp sequence: a fixed pseudo-random sequence of every stamp kind on both
// layers (integer LCG, no libm: protocol/stamps/stamp_mix.h with its default options),
// applied to a flat world. Its content hash pins the profile
// table baking and every kernel: the GCC unit tests and a clang-built check in CI
// (tests/determinism/golden_check.cpp, built with the fuzzers) must both reproduce it.
// No GoogleTest here, so the clang build can compile it with protocol/ and tests/support/.
#pragma once

#include <cstdint>
#include <string>

namespace loam::determinism {

inline constexpr uint64_t kGoldenStampSequenceHash = 0xc875caa4907e2017ull;

// Content hash (World::legacy_content_hash: every tile) after the sequence; `error` gets the first stamp that
// failed (should be none).
uint64_t golden_stamp_sequence_hash(std::string* error);

}  // namespace loam::determinism
