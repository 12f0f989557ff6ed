// OpenEXR DEMs read through OpenImageIO (GDAL has no EXR reader here): Loam's own float
// exports (dem_export.h) and float heights from other tools. Scanline or tiled files, read a
// strip of rows at a time; channels are bands (1-based). OpenEXR files carry no CRS.
// Every read's status is checked; a short or corrupt file gives an Error.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "dem/raster_source.h"

namespace loam {

Result<std::unique_ptr<RasterSource>> open_exr_file(const std::string& path);

// `bytes` must outlive the source.
Result<std::unique_ptr<RasterSource>> open_exr_memory(std::span<const uint8_t> bytes,
                                                      const std::string& name);

}  // namespace loam
