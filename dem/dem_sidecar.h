// The JSON sidecar beside a DEM (NAME.json): the format of shared/data and of Loam's own
// exports. Keys read: meters_per_sample_xy [x, y] (or meters_per_sample), height_scale_m,
// height_offset_m, width, height, sample_type, and loam_world (a Loam world's quantization).
//
// Safe on untrusted input: a sidecar that does not parse, a known key of the wrong JSON type
// or out of range, or (check_sidecar_matches) dimensions, sample type or loam_world tiles that
// do not match the image is an Error naming the sidecar and the key. Unknown keys are ignored.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "dem/dem_raster.h"
#include "protocol/result.h"

namespace loam {

struct Sidecar {
  std::optional<double> meters_per_sample;
  double anisotropy = 1.0;  // y spacing / x spacing
  std::optional<double> vertical_scale;
  std::optional<double> vertical_offset;
  std::optional<int64_t> width, height;
  std::optional<std::string> sample_type;
  std::optional<LoamSidecarWorld> loam_world;
};

// `name` names the sidecar in messages.
Result<Sidecar> parse_sidecar(const std::string& text, const std::string& name);

// The sidecar describes this image: width, height and sample type (when given) agree, and a
// loam_world covers exactly ceil(width / 256) x ceil(height / 256) tiles.
Status check_sidecar_matches(const Sidecar& s, int64_t width, int64_t height, const std::string& sample_type,
                             const std::string& name);

}  // namespace loam
