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
//
// A geographic DEM's samples are not square in metres, and their east-west size changes with
// latitude. Import either takes the geometric mean spacing at the centre for both axes (the
// default) or warps the raster to a local projected CRS first (LocalProjection, through GDAL:
// gdal_source.h), and reports the distortion either way (geographic_distortion).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

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

// The local projected CRS a geographic DEM is warped to before import: none, an azimuthal
// equidistant projection centred on the raster (distances from the centre exact), or the UTM
// zone of the raster's centre.
enum class LocalProjection : uint8_t { kNone, kAzimuthalEquidistant, kUtm };
// "none", "aeqd" or "utm"; errors say what is accepted.
Result<LocalProjection> parse_local_projection(std::string_view text);
const char* to_string(LocalProjection p);

// The raster's centre in degrees (longitude, latitude), for a geographic CRS with a transform.
struct GeoCentre {
  double lon = 0, lat = 0;
};
std::optional<GeoCentre> geographic_centre(const Georef& g, int64_t width, int64_t height);

// UTM zone (1..60) of a longitude.
int utm_zone(double lon);

// How far a geographic raster's distances are off in Loam's square samples, for the report
// (on the sphere, to a few per cent of the error itself): with kNone, the east-west spacing's
// change from the centre to the northern and southern edges and the stretch that squaring
// the samples puts on each axis; projected, the projection's largest scale error over the
// raster's corners and edge midpoints. Empty for a raster that is not geographic.
std::string geographic_distortion(const Georef& g, int64_t width, int64_t height, LocalProjection p);

}  // namespace loam
