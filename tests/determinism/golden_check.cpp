// Built by the clang (fuzz) configuration and run by fuzz/run.sh: the golden stamp sequence
// must reproduce the same world hash with clang as the GCC unit tests check.
#include <cstdio>
#include <string>

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
  return ok ? 0 : 1;
}
