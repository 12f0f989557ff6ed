#include "dem/stamp_texture_io.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>

#include "dem/exr_source.h"
#include "dem/gdal_source.h"

namespace loam {
namespace {

Error fail(ErrorCode code, const std::string& name, const std::string& why) {
  return make_error(code, name, why);
}

// Float samples: clamp to [0, 1] and round to nearest 1/65535 (halves up; exact in double).
Result<uint16_t> from_float(double v, const std::string& name) {
  if (!std::isfinite(v)) return fail(ErrorCode::kNotFinite, name, "a float sample is NaN or infinite");
  const double c = v < 0.0 ? 0.0 : v > 1.0 ? 1.0 : v;
  return uint16_t(std::floor(c * 65535.0 + 0.5));
}

}  // namespace

Result<DecodedTexture> read_stamp_texture_memory(std::span<const uint8_t> bytes, const std::string& name) {
  const std::string ext = lower_extension(name);
  if (ext != "png" && ext != "tif" && ext != "tiff" && ext != "exr") {
    return fail(ErrorCode::kUnsupported, name,
                "unsupported texture format '" + ext + "' (use PNG, TIFF or EXR)");
  }
  // The DEM readers: GDAL for PNG and TIFF, OpenEXR for EXR; opening reads the header only.
  auto opened = ext == "exr" ? open_exr_memory(bytes, name) : open_gdal_memory(bytes, name, ext);
  if (!opened.ok()) {
    return fail(ErrorCode::kCorrupt, name, "cannot decode the texture: " + opened.error().message);
  }
  RasterSource& src = *opened.value();
  if (src.width() <= 0 || src.height() <= 0 || src.band_count() <= 0) {
    return fail(ErrorCode::kCorrupt, name, "texture has no samples");
  }
  const RasterBandInfo gray = src.band(1);
  if (src.band_count() > 2 || gray.color == "Palette") {
    return fail(ErrorCode::kUnsupported, name,
                gray.color == "Palette"
                    ? std::string("texture is a palette (colour) image; stamps take grayscale")
                    : "texture has " + std::to_string(src.band_count()) +
                          " channels; stamps take grayscale (1, or 2 with alpha)");
  }
  if (src.width() > kMaxTextureSide || src.height() > kMaxTextureSide) {
    return fail(ErrorCode::kOversize, name,
                "texture is " + std::to_string(src.width()) + "x" + std::to_string(src.height()) +
                    "; the limit is " + std::to_string(kMaxTextureSide) + " per side");
  }
  const std::string& type = gray.sample_type;
  const bool is_float = type == "float16" || type == "float32" || type == "float64";
  if (type != "uint8" && type != "uint16" && !is_float) {
    return fail(ErrorCode::kUnsupported, name,
                "unsupported sample type " + type + " (use 8/16-bit unsigned or float)");
  }
  DecodedTexture t;
  t.width = int32_t(src.width());
  t.height = int32_t(src.height());
  const size_t count = size_t(t.width) * size_t(t.height);
  // The first channel only, a strip of rows at a time (a double holds every integer and
  // half/float sample exactly).
  t.samples.resize(count);
  const int bits = gray.bits > 0 && gray.bits < 8 ? gray.bits : 8;
  // 1-, 2- and 4-bit gray widen to 8 bits by repeating their bits (PNG's own rule: 1 -> 255).
  const uint32_t widen = 255u / ((1u << bits) - 1u);
  const int64_t strip = std::max<int64_t>(src.block_rows(), 64);
  std::vector<double> v;
  for (int64_t y0 = 0; y0 < t.height; y0 += strip) {
    const int64_t rows = std::min<int64_t>(strip, t.height - y0);
    v.resize(size_t(rows) * size_t(t.width));
    if (auto r = src.read_rows(1, y0, rows, v); !r.ok()) {
      return fail(ErrorCode::kCorrupt, name, "cannot read the texture's samples: " + r.error().message);
    }
    uint16_t* out = t.samples.data() + size_t(y0) * size_t(t.width);
    for (size_t i = 0; i < v.size(); ++i) {
      if (type == "uint8") {
        out[i] = uint16_t(uint32_t(v[i]) * widen * 257u);
      } else if (type == "uint16") {
        out[i] = uint16_t(v[i]);
      } else {
        auto s = from_float(v[i], name);
        if (!s.ok()) return s.error();
        out[i] = s.value();
      }
    }
  }
  return t;
}

Result<DecodedTexture> read_stamp_texture_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return fail(ErrorCode::kNotFound, path, "cannot open the texture file");
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (f.bad()) return fail(ErrorCode::kIo, path, "error while reading the texture file");
  return read_stamp_texture_memory(bytes, path);
}

Result<uint64_t> register_stamp_texture_file(TextureRegistry& registry, const std::string& path) {
  auto t = read_stamp_texture_file(path);
  LOAM_TRY(t);
  auto id = registry.add(t.value().width, t.value().height, t.value().samples);
  if (!id.ok()) return fail(id.error().code, path, id.error().message);
  return id.value();
}

}  // namespace loam
