// DEM rasters read through GDAL: GeoTIFF/COG (.tif, .tiff), PNG (.png), SRTM HGT (.hgt,
// named like N47E011.hgt), ESRI ASCII grid (.asc) and VRT (.vrt). The extension picks the one
// GDAL driver allowed to open the file, so a file is never read by a driver its name does not
// announce.
//
// Safe on untrusted input in the sense the rest of dem/ relies on: opening reads the header
// only, reads go through RasterIO with every CPLErr checked, and GDAL's errors and warnings
// are captured (never printed) and become the Error's message. GDAL's block cache is capped
// (64 MiB) the first time a raster is opened. Not thread-safe: one source per thread.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "dem/dem_georef.h"
#include "dem/raster_source.h"

namespace loam {

// The GDAL driver for a lower-case extension ("tif" -> "GTiff"), or nullptr.
const char* gdal_driver_for_extension(const std::string& ext);

// Opens a file. `ext` is the file's lower-case extension (see gdal_driver_for_extension).
Result<std::unique_ptr<RasterSource>> open_gdal_file(const std::string& path, const std::string& ext);

// Opens bytes held in memory (GDAL's /vsimem/, without a copy): `bytes` must outlive the
// source. `name` is used for messages and for drivers that read the name (SRTM HGT).
Result<std::unique_ptr<RasterSource>> open_gdal_memory(std::span<const uint8_t> bytes,
                                                       const std::string& name, const std::string& ext);

// Warps a geographic raster opened here to the local projected CRS `projection` names (its
// datum kept), as gdalwarp would: square samples of the size GDAL suggests for the raster,
// bilinear resampling, heights as float64 and NaN outside the source's footprint. The source's
// NoData stays NoData. Read lazily, strip by strip, like any raster. Errors name `name`.
Result<std::unique_ptr<RasterSource>> project_gdal_source(std::unique_ptr<RasterSource> source,
                                                          LocalProjection projection,
                                                          const std::string& name);

}  // namespace loam
