// OpenEXR DEMs read through the OpenEXR library (GDAL has no EXR reader here): Loam's own
// float exports (dem_export.h) and float heights from other tools. Scanline or tiled files,
// read a strip of rows at a time; channels are bands (1-based: R, G, B, Y, A, then the rest by
// name). OpenEXR files carry no CRS. Every read is checked; a short or corrupt file gives an
// Error, and a header claiming sides over a million samples is refused before anything is read.
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
