// Stamp texture images from files: a grayscale PNG, TIFF or EXR decoded by the DEM readers
// (GDAL for PNG and TIFF, OpenEXR for EXR) into the 16-bit samples TextureRegistry::add takes
// (protocol/ stays free of image libraries).
//
// Sample mapping, chosen so every party that decodes the same file registers the same
// content id: 16-bit integers as they are; 8-bit integers times 257 (0 -> 0, 255 -> 65535),
// 1-, 2- and 4-bit gray first widened to 8 bits as PNG defines (1-bit 1 -> 255);
// floating point (half, float, double) clamped to [0, 1], times 65535, rounded to nearest
// (halves up). One channel, or two (gray + alpha: alpha is ignored). Row 0 of the file is
// row 0 of the texture. Safe on untrusted files: every failure is an Error whose field is
// the file's name (kNotFound, kUnsupported, kOversize, kCorrupt, kNotFinite).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "protocol/result.h"
#include "protocol/stamps/texture_registry.h"

namespace loam {

struct DecodedTexture {
  int32_t width = 0;
  int32_t height = 0;
  std::vector<uint16_t> samples;  // row-major, width * height
};

// Decodes the file at `path` (format from its extension: png, tif, tiff, exr).
Result<DecodedTexture> read_stamp_texture_file(const std::string& path);

// Decodes an in-memory file; `name` gives the format (by extension) and names errors.
Result<DecodedTexture> read_stamp_texture_memory(std::span<const uint8_t> bytes, const std::string& name);

// Decodes `path` and registers it; returns the content id.
Result<uint64_t> register_stamp_texture_file(TextureRegistry& registry, const std::string& path);

}  // namespace loam
