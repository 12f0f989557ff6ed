// Reads the GeoTIFF/GDAL tags OpenImageIO does not expose: GDAL_NODATA (42113) and
// ModelPixelScale (33550), from the first image directory of a classic or Big TIFF.
//
// Safe on untrusted input: every offset and count is checked against the buffer before it is
// read; a malformed file gives an Error, never a read out of bounds.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "protocol/result.h"

namespace loam {

struct TiffGeoTags {
  std::optional<double> nodata;         // GDAL_NODATA parsed as a number
  std::optional<double> pixel_scale_x;  // ModelPixelScale[0]
  std::optional<double> pixel_scale_y;  // ModelPixelScale[1]
};

// `bytes` is the whole file. Files that are not TIFF give an empty TiffGeoTags.
Result<TiffGeoTags> read_tiff_geo_tags(std::span<const uint8_t> bytes);

}  // namespace loam
