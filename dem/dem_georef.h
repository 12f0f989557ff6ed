// Metres per sample from a raster's georeferencing.
//
// - Geographic CRS (degrees): the spacing at the raster's centre latitude on the CRS's
//   ellipsoid: x = N(lat) cos(lat) dlon, y = M(lat) dlat (N, M: the prime-vertical and
//   meridional radii of curvature), the way shared/data's ETOPO5 sidecar states it. A centre
//   latitude outside -90..90 (a transform not in degrees) or at a pole is an Error naming the
//   CRS.
// - Projected or local CRS: the transform's pixel size times the CRS's linear unit (feet and
//   US survey feet become metres).
// - No CRS but a transform (an ASCII grid without .prj): the pixel size, taken as metres.
// - Any other CRS (geocentric...): an Error naming it.
// Rotated transforms use the length of each pixel axis.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "dem/raster_source.h"
#include "protocol/result.h"

namespace loam {

struct GeoSpacing {
  double x_m = 0, y_m = 0;  // metres per sample along a row and along a column
  std::string note;         // how it was derived, for the import report
};

// nullopt when the raster has no geotransform. `name` is the file, for messages.
Result<std::optional<GeoSpacing>> spacing_from_georef(const Georef& g, int64_t width, int64_t height,
                                                      const std::string& name);

}  // namespace loam
