#include "dem/image_file.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <cpl_conv.h>
#include <gdal.h>

#include <cstddef>
#include <exception>
#include <vector>

#include "dem/gdal_errors.h"
#include "dem/raster_source.h"

namespace loam {
namespace {

size_t sample_bytes(ImageSampleType t) {
  switch (t) {
    case ImageSampleType::kUint8: return 1;
    case ImageSampleType::kUint16: return 2;
    case ImageSampleType::kFloat32: return 4;
  }
  return 1;
}

// PNG and TIFF: the pixels copied into a GDAL in-memory dataset, which the format's driver
// copies out.
Status write_with_gdal(const std::string& path, const ImageView& im, const char* driver_name) {
  ensure_gdal_ready();
  GdalErrorCapture errors;
  const GDALDataType type = im.type == ImageSampleType::kUint8    ? GDT_Byte
                            : im.type == ImageSampleType::kUint16 ? GDT_UInt16
                                                                  : GDT_Float32;
  GDALDriverH mem = GDALGetDriverByName("MEM");
  GDALDriverH out = GDALGetDriverByName(driver_name);
  if (!mem || !out) {
    return make_error(ErrorCode::kUnsupported, path,
                      std::string("GDAL lacks the ") + driver_name + " driver");
  }
  GDALDatasetH src = GDALCreate(mem, "", im.width, im.height, im.channels, type, nullptr);
  if (!src) return make_error(ErrorCode::kIo, path, "cannot hold the image: " + errors.text("GDAL error"));
  const GSpacing s = GSpacing(sample_bytes(im.type));
  const GSpacing pixel = s * im.channels, line = pixel * im.width;
  bool ok = GDALDatasetRasterIOEx(src, GF_Write, 0, 0, im.width, im.height,
                                  const_cast<std::byte*>(im.samples.data()), im.width, im.height, type,
                                  im.channels, nullptr, pixel, line, s, nullptr) == CE_None;
  const bool alpha = im.channels == 2 || im.channels == 4;
  if (ok && alpha) GDALSetRasterColorInterpretation(GDALGetRasterBand(src, im.channels), GCI_AlphaBand);
  const bool tiff = std::string(driver_name) == "GTiff";
  const char* tiff_options[] = {"COMPRESS=DEFLATE", alpha ? "ALPHA=UNASSOCIATED" : nullptr, nullptr};
  GDALDatasetH dst = nullptr;
  if (ok) {
    // No .aux.xml sidecar: the file holds everything written.
    CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", "NO");
    dst = GDALCreateCopy(out, path.c_str(), src, FALSE, tiff ? const_cast<char**>(tiff_options) : nullptr,
                         nullptr, nullptr);
    CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", nullptr);
  }
  // Errors while flushing on close are raised as CPLErrors (captured above).
  if (dst) GDALClose(dst);
  GDALClose(src);
  ok = ok && dst && !errors.failed();
  if (!ok) return make_error(ErrorCode::kIo, path, "cannot write: " + errors.text("GDAL error"));
  return {};
}

Status write_exr(const std::string& path, const ImageView& im) {
  if (im.type != ImageSampleType::kFloat32) {
    return make_error(ErrorCode::kUnsupported, path, "OpenEXR files are written as 32-bit float");
  }
  static const char* const kNames[4][4] = {{"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
  try {
    Imf::Header header(im.width, im.height);
    header.compression() = Imf::ZIP_COMPRESSION;
    Imf::FrameBuffer fb;
    const size_t px = sizeof(float) * size_t(im.channels);
    auto* base = const_cast<char*>(reinterpret_cast<const char*>(im.samples.data()));
    for (int32_t c = 0; c < im.channels; ++c) {
      const char* name = kNames[im.channels - 1][c];
      header.channels().insert(name, Imf::Channel(Imf::FLOAT));
      fb.insert(name, Imf::Slice(Imf::FLOAT, base + size_t(c) * sizeof(float), px, px * size_t(im.width)));
    }
    Imf::OutputFile file(path.c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(im.height);
  } catch (const std::exception& e) {
    return make_error(ErrorCode::kIo, path, std::string("cannot write: ") + e.what());
  }
  return {};
}

}  // namespace

ImageView image_view(int32_t width, int32_t height, int32_t channels, std::span<const uint8_t> samples) {
  return {width, height, channels, ImageSampleType::kUint8, std::as_bytes(samples)};
}
ImageView image_view(int32_t width, int32_t height, int32_t channels, std::span<const uint16_t> samples) {
  return {width, height, channels, ImageSampleType::kUint16, std::as_bytes(samples)};
}
ImageView image_view(int32_t width, int32_t height, int32_t channels, std::span<const float> samples) {
  return {width, height, channels, ImageSampleType::kFloat32, std::as_bytes(samples)};
}

Status write_image_file(const std::string& path, const ImageView& im) {
  if (im.width < 1 || im.height < 1 || im.channels < 1 || im.channels > 4 ||
      im.samples.size() !=
          size_t(im.width) * size_t(im.height) * size_t(im.channels) * sample_bytes(im.type)) {
    return make_error(ErrorCode::kInvalidArgument, path, "image size and samples do not match");
  }
  const std::string ext = lower_extension(path);
  if (ext == "png") {
    if (im.type == ImageSampleType::kFloat32) {
      return make_error(ErrorCode::kUnsupported, path, "PNG holds 8- or 16-bit samples, not float");
    }
    return write_with_gdal(path, im, "PNG");
  }
  if (ext == "tif" || ext == "tiff") return write_with_gdal(path, im, "GTiff");
  if (ext == "exr") return write_exr(path, im);
  return make_error(ErrorCode::kUnsupported, path,
                    "no image writer for '" + ext + "' (use .png, .tif, .tiff or .exr)");
}

}  // namespace loam
