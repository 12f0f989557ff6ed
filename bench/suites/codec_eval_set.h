// The region codec's evaluation set: DEMs the codec is never tuned against, made here from
// fixed recipes (windows of the shared DEMs resampled and quantized at other steps, synthetic
// fBm, eroded, ridged and terraced terrain, flat and noisy extremes), with vertical units of
// 1 m, 0.1 m and 1 cm, sizes from a single tile with its apron to several tiles, and spacings
// from 2 m to 900 m. The `codec` suite reports them apart from the tuning set (data/ and
// ../shared/data) and checks each against the frozen manifest bench/codec_eval_set.txt, so a
// change to a recipe cannot pass unnoticed as a codec gain.
//
// Deterministic: noise comes from a hash of integer coordinates (no <random> distributions,
// whose output the standard leaves to each library), resampling is plain double arithmetic.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dem/dem_import.h"
#include "protocol/result.h"

namespace loam::bench {

struct EvalDem {
  std::string name;
  std::string what;  // its recipe, in words
  ImportedWorld imported;
};

// Builds the set; windows of the shared DEMs are skipped (and listed in `skipped`) when
// `shared_data_dir` lacks them.
std::vector<EvalDem> codec_evaluation_set(const std::string& shared_data_dir,
                                          std::vector<std::string>& skipped);

// A manifest line: name, world hash (16 hex digits), size, recipe, tab-separated.
struct EvalManifestEntry {
  std::string name;
  uint64_t world_hash = 0;
};
Result<std::vector<EvalManifestEntry>> read_eval_manifest(const std::string& path);
std::string eval_manifest_line(const EvalDem& d);

}  // namespace loam::bench
