// Reading elevation rasters (DEMs).
//
// Formats, by extension: GeoTIFF/COG (.tif, .tiff), PNG (.png), SRTM HGT (.hgt, named like
// N47E011.hgt), ESRI ASCII grid (.asc) and VRT (.vrt) through GDAL; OpenEXR (.exr, Loam's
// float exports) through the OpenEXR library. Samples may be 8/16/32-bit integers or floats. Heights
// come out in metres as double, NaN where the source has no data (NaN samples, or the band's
// NoData value); the band's scale and offset apply.
//
// A DEM has one height band. Multi-band images (RGB, RGBA, gray+alpha) and palette images are
// refused unless the caller names the band (DemScaleOptions::band).
//
// Horizontal scale, in order of precedence: explicit options, a JSON sidecar beside the file
// (NAME.json: dem_sidecar.h), the georeferencing (dem_georef.h: a geographic CRS gives metres
// at the centre latitude, a projected one its linear unit), or 1 m per sample. Vertical:
// explicit options, the sidecar, the band's scale/offset (and its unit: feet become metres),
// or identity. The raster's scale_source and scale_note say which.
//
// Orientation: a geotransform with a positive row step (south-up) or a negative column step
// (east-left) is read flipped, exactly (no resampling), so row 0 is always the north edge and
// DemInfo::orientation says what was done; a rotated or sheared geotransform is refused with the
// gdalwarp command that makes the raster north-up.
//
// ESRI ASCII grids are checked as text first (dem/ascii_grid_check.h): GDAL would read a
// cell that is not a number as 0.
//
// Safe on untrusted input: the file is read in strips of rows, so memory grows with the data
// actually decoded and never with the size a header claims; a raster over kMaxDemSamples
// (2^28 samples) or 2^20 samples a side is refused before any sample is read; truncated or
// corrupt data, a sidecar that does not match the image, and a NaN/NoData-only raster are
// Errors naming the file and the reason. Nothing here throws.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "dem/dem_georef.h"
#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam {

// Refused before reading: more samples than this, or more than kMaxDemSide a side.
inline constexpr int64_t kMaxDemSamples = int64_t(1) << 28;
inline constexpr int64_t kMaxDemSide = int64_t(1) << 20;

struct DemScaleOptions {
  std::optional<double> meters_per_sample;  // horizontal spacing
  std::optional<double> vertical_scale;     // meters per source unit
  std::optional<double> vertical_offset;    // meters at source value 0
  std::optional<int> band;                  // the height band (1-based); required for multi-band images
  // A geographic DEM warped to a local projected CRS first (dem_georef.h), so its samples are
  // square metres; kNone takes the centre's mean spacing. Only for GDAL rasters in degrees
  // without a sidecar or --meters-per-sample stating the spacing.
  LocalProjection project = LocalProjection::kNone;
};

// A Loam world's own quantization, when a sidecar carries it (exports do): importing such
// a file reproduces the world bit for bit.
struct LoamSidecarWorld {
  WorldParams params;
};

// What a DEM says about itself and how its values become metres, without its samples.
struct DemInfo {
  std::string name;  // file name, for messages
  int64_t width = 0;
  int64_t height = 0;
  double meters_per_sample = 1.0;
  double anisotropy = 1.0;  // source y spacing / x spacing (1 = square samples)
  bool integer_source = false;
  double vertical_step = 0.0;  // meters per source unit for integer sources, else 0
  std::string scale_source;    // horizontal: "explicit", "sidecar", "georeferencing" or "default"
  std::string scale_note;      // how georeferencing gave the spacing (CRS, centre latitude), else empty
  std::string format;          // the reader: "GTiff", "PNG", "SRTMHGT", "AAIGrid", "VRT", "OpenEXR"
  std::string sample_type;     // the band's: "uint16", "int16", "float32"...
  int band = 1;                // the band read
  std::optional<LoamSidecarWorld> loam_world;  // set when the sidecar holds Loam's quantization
  // How the source's rows and columns were turned to give row 0 north and column 0 west:
  // "north-up", "south-up (rows flipped)", "east-left (columns flipped)" or both flipped.
  std::string orientation = "north-up";
  std::string distortion;  // a geographic DEM's: how far distances are off (dem_georef.h)
};

struct DemRaster : DemInfo {
  std::vector<double> meters;  // row-major, row 0 first (north); NaN = no data
  int64_t nodata_count = 0;
};

// A DEM opened for reading in strips of rows, for imports that never hold the whole raster
// (a tile pack: dem/pack_import.h). Opening reads the header, the sidecar and the band's
// scale; read_rows() then gives metres, NaN where the source has no data. Rasters up to
// kMaxStreamedDemSide a side open (any sample count within that). Not thread-safe.
inline constexpr int64_t kMaxStreamedDemSide = int64_t(1) << 17;

class RasterSource;

class DemStrips {
 public:
  DemStrips(DemStrips&&) noexcept;
  DemStrips& operator=(DemStrips&&) noexcept;
  ~DemStrips();

  const DemInfo& info() const { return info_; }
  // Rows per read that keep one read within about 8 MiB of doubles (whole storage blocks
  // where they fit).
  int64_t strip_rows() const;
  // Rows [y0, y0 + rows) in metres, row-major, into `out` (rows * width values); returns the
  // number of NaN/NoData samples among them. Decoder errors and short reads are Errors.
  Result<int64_t> read_rows(int64_t y0, int64_t rows, std::span<double> out);

 private:
  friend struct DemStripsOpener;
  DemStrips() = default;
  DemInfo info_;
  std::unique_ptr<RasterSource> src_;
  std::optional<double> nodata_;
  double scale_ = 1.0, offset_ = 0.0;
  bool flip_rows_ = false, flip_columns_ = false;  // the source is south-up / east-left
};

// Opens a DEM file for strip reads (the sidecar NAME.json beside it is used when present).
Result<DemStrips> open_dem_strips(const std::string& path, const DemScaleOptions& options = {});

// Reads a DEM file. The sidecar NAME.json beside it is used when present.
Result<DemRaster> read_dem_file(const std::string& path, const DemScaleOptions& options = {});

// Reads a DEM from memory (for the embedded default terrain). `name` must carry the format's
// extension (e.g. "default.png"); `sidecar_json` may be empty.
Result<DemRaster> read_dem_memory(std::span<const uint8_t> bytes, const std::string& name,
                                  const std::string& sidecar_json, const DemScaleOptions& options = {});

}  // namespace loam
