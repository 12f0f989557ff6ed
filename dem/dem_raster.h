// Reading elevation rasters (DEMs) from image files through OpenImageIO.
//
// Accepts 16-bit (and 8-bit) integer PNG/TIFF and float TIFF/EXR, single channel (the first
// channel of a multi-channel image is used). Heights come out in meters as double, NaN where
// the source has no data (NaN samples, or TIFF GDAL_NODATA). Scale comes, in order of
// precedence, from explicit options, a JSON sidecar beside the file (NAME.json, the format of
// shared/data and of Loam's own exports), GeoTIFF ModelPixelScale, or defaults (1 m per
// sample; integer sources 1 m per unit, float sources in meters), and the report says which.
// Every failure is an Error naming the file and the reason; nothing here throws.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam {

struct DemScaleOptions {
  std::optional<double> meters_per_sample;  // horizontal spacing
  std::optional<double> vertical_scale;     // meters per source unit (integer sources)
  std::optional<double> vertical_offset;    // meters at source value 0 (integer sources)
};

// A Loam world's own quantization, when a sidecar carries it (exports do): importing such
// a file reproduces the world bit for bit.
struct LoamSidecarWorld {
  WorldParams params;
};

struct DemRaster {
  std::string name;  // file name, for messages
  int64_t width = 0;
  int64_t height = 0;
  std::vector<double> meters;  // row-major, row 0 first (north); NaN = no data
  double meters_per_sample = 1.0;
  double anisotropy = 1.0;  // source y spacing / x spacing (1 = square samples)
  bool integer_source = false;
  double vertical_step = 0.0;  // meters per source unit for integer sources, else 0
  int64_t nodata_count = 0;
  std::string scale_source;                    // "explicit", "sidecar", "geotiff" or "default"
  std::optional<LoamSidecarWorld> loam_world;  // set when the sidecar holds Loam's quantization
};

// Reads a DEM file. The sidecar NAME.json beside it is used when present.
Result<DemRaster> read_dem_file(const std::string& path, const DemScaleOptions& options = {});

// Reads a DEM from memory (for the embedded default terrain). `name` must carry the format's
// extension (e.g. "default.png"); `sidecar_json` may be empty.
Result<DemRaster> read_dem_memory(std::span<const uint8_t> bytes, const std::string& name,
                                  const std::string& sidecar_json, const DemScaleOptions& options = {});

}  // namespace loam
