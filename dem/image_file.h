// Image files Loam writes: exports, screenshots, test rasters. PNG and TIFF go through GDAL,
// which every program that writes images already links for DEMs; OpenEXR through the OpenEXR
// library. No general image library: it would cost every Loam process the start-up of a few
// hundred shared libraries (about 0.5 s and 130 MB each), whether it writes an image or not.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "protocol/result.h"

namespace loam {

enum class ImageSampleType : uint8_t { kUint8, kUint16, kFloat32 };

// Pixels row-major, top row first, channels interleaved (1 gray, 2 gray + alpha, 3 RGB,
// 4 RGBA); `samples` holds width * height * channels values of the one sample type.
struct ImageView {
  int32_t width = 0;
  int32_t height = 0;
  int32_t channels = 1;
  ImageSampleType type = ImageSampleType::kUint8;
  std::span<const std::byte> samples;
};

ImageView image_view(int32_t width, int32_t height, int32_t channels, std::span<const uint8_t> samples);
ImageView image_view(int32_t width, int32_t height, int32_t channels, std::span<const uint16_t> samples);
ImageView image_view(int32_t width, int32_t height, int32_t channels, std::span<const float> samples);

// Writes `image` to `path`; the extension (any case) picks the format: .png (8- or 16-bit),
// .tif/.tiff (any sample type, deflate), .exr (32-bit float, zip; channels named Y, YA, RGB or
// RGBA). Errors: kUnsupported (extension or sample type), kInvalidArgument (a view whose size
// does not match), kIo (the file cannot be written), each naming `path`.
Status write_image_file(const std::string& path, const ImageView& image);

}  // namespace loam
