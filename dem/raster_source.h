// A raster file opened for reading DEM samples: its size, its bands, its georeferencing,
// and reads of whole rows (strips), so a DEM is read in windows and memory follows the data
// actually read, never the size a header claims.
//
// Two implementations: GDAL (gdal_source.h: GeoTIFF/COG, PNG, SRTM HGT, ESRI ASCII grid,
// VRT) and the OpenEXR library (exr_source.h: Loam's own float exports). Opening reads
// only the header; every read checks the decoder's status, so truncated or corrupt data is an
// Error, never rows of zeros. Not thread-safe: one source per thread.
#pragma once

#include <cctype>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>

#include "protocol/result.h"

namespace loam {

struct RasterBandInfo {
  std::string sample_type;       // "uint8", "uint16", "int16", "uint32", "int32", "float32", "float64"...
  bool integer = false;          // an integer sample type
  bool supported = false;        // a sample type a DEM may have (real, 8..32-bit integer or float)
  std::string color;             // colour interpretation: "Gray", "Red", "Alpha", "Palette", "Undefined"...
  std::optional<double> nodata;  // the band's NoData value (may be NaN)
  std::optional<double> scale;   // the band's value scale (value * scale + offset)
  std::optional<double> offset;  // the band's value offset
  std::string unit;              // the band's unit ("m", "ft", or empty)
  int bits = 0;                  // significant bits of a narrower integer (a 1-, 2- or 4-bit PNG); 0: all
};

// Where the samples lie on the earth: the affine geotransform (GDAL's order: x0, dx/col,
// dx/row, y0, dy/col, dy/row) and the coordinate reference system's kind and units.
struct Georef {
  enum class Crs { kNone, kGeographic, kProjected, kLocal, kOther };
  bool has_transform = false;
  double transform[6] = {0, 1, 0, 0, 0, 1};
  Crs crs = Crs::kNone;
  std::string crs_name;             // e.g. "WGS 84", "NAD83 / UTM zone 10N"
  double angular_unit_deg = 1.0;    // degrees per angular unit (geographic)
  double semi_major_m = 0.0;        // ellipsoid (geographic)
  double inverse_flattening = 0.0;  // 0: a sphere
  double linear_unit_m = 1.0;       // metres per linear unit (projected, local)
  std::string linear_unit_name;     // "metre", "US survey foot"...
};

// The lower-case extension of a file name without its dot ("png"); empty when it has none. The
// extension picks the reader (and the writer, dem/image_file.h).
inline std::string lower_extension(const std::string& name) {
  std::string ext = std::filesystem::path(name).extension().string();
  if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

class RasterSource {
 public:
  virtual ~RasterSource() = default;
  virtual int64_t width() const = 0;
  virtual int64_t height() const = 0;
  virtual int band_count() const = 0;
  virtual RasterBandInfo band(int index) const = 0;  // index in 1..band_count()
  virtual Georef georef() const = 0;
  virtual std::string format() const = 0;  // "GTiff", "PNG", "SRTMHGT", "AAIGrid", "VRT", "OpenEXR"
  // The rows of one storage block (a strip or a tile row): reads start at multiples of it.
  virtual int64_t block_rows() const { return 1; }

  // Reads rows [y0, y0 + rows) of band `index` (1-based) as doubles, row-major, into `out`
  // (exactly rows * width() values). Any decoder error or short read is an Error.
  virtual Status read_rows(int index, int64_t y0, int64_t rows, std::span<double> out) = 0;
};

}  // namespace loam
