// Built by the clang (fuzz) configuration and run by fuzz/run.sh: the golden stamp sequence
// and the golden refinement must reproduce the same hashes with clang as the GCC unit tests
// check.
#include <cstdio>
#include <string>

#include "tests/determinism/refinement_sequence.h"
#include "tests/determinism/stamp_sequence.h"

int main() {
  std::string error;
  const uint64_t got = loam::determinism::golden_stamp_sequence_hash(&error);
  if (!error.empty()) {
    std::fprintf(stderr, "golden stamp sequence: %s\n", error.c_str());
    return 1;
  }
  const bool ok = got == loam::determinism::kGoldenStampSequenceHash;
  std::printf("golden stamp sequence (clang %d.%d): world hash %016llx, expected %016llx: %s\n",
              __clang_major__, __clang_minor__, (unsigned long long)got,
              (unsigned long long)loam::determinism::kGoldenStampSequenceHash, ok ? "same" : "DIFFERENT");
  const uint64_t refined = loam::determinism::golden_refinement_hash();
  const bool refined_ok = refined == loam::determinism::kGoldenRefinementHash;
  std::printf("golden refinement (clang %d.%d): hash %016llx, expected %016llx: %s\n", __clang_major__,
              __clang_minor__, (unsigned long long)refined,
              (unsigned long long)loam::determinism::kGoldenRefinementHash,
              refined_ok ? "same" : "DIFFERENT");
  return ok && refined_ok ? 0 : 1;
}
