#include "dem/stamp_texture_io.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cctype>
#include <cmath>
#include <fstream>
#include <iterator>

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
  std::string ext = OIIO::Filesystem::extension(name, false);
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext != "png" && ext != "tif" && ext != "tiff" && ext != "exr") {
    return fail(ErrorCode::kUnsupported, name,
                "unsupported texture format '" + ext + "' (use PNG, TIFF or EXR)");
  }
  // OIIO reads through the proxy and never writes to it; the API takes a non-const pointer.
  OIIO::Filesystem::IOMemReader proxy(const_cast<uint8_t*>(bytes.data()), bytes.size());
  auto in = OIIO::ImageInput::create(ext);
  OIIO::ImageSpec spec;
  // Gray + alpha: the gray channel as stored, never premultiplied by alpha (PNG's default).
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  if (!in || !in->set_ioproxy(&proxy) || !in->open(name, spec, config)) {
    std::string why = in ? in->geterror() : OIIO::geterror();
    if (why.empty()) why = "not a readable image";
    return fail(ErrorCode::kCorrupt, name, "cannot decode the texture: " + why);
  }
  spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) {
    return fail(ErrorCode::kCorrupt, name, "texture has no samples");
  }
  if (spec.nchannels > 2) {
    return fail(ErrorCode::kUnsupported, name,
                "texture has " + std::to_string(spec.nchannels) +
                    " channels; stamps take grayscale (1, or 2 with alpha)");
  }
  if (spec.width > kMaxTextureSide || spec.height > kMaxTextureSide) {
    return fail(ErrorCode::kOversize, name,
                "texture is " + std::to_string(spec.width) + "x" + std::to_string(spec.height) +
                    "; the limit is " + std::to_string(kMaxTextureSide) + " per side");
  }
  const auto base = OIIO::TypeDesc::BASETYPE(spec.format.basetype);
  const bool is_float =
      base == OIIO::TypeDesc::HALF || base == OIIO::TypeDesc::FLOAT || base == OIIO::TypeDesc::DOUBLE;
  if (base != OIIO::TypeDesc::UINT8 && base != OIIO::TypeDesc::UINT16 && !is_float) {
    return fail(
        ErrorCode::kUnsupported, name,
        std::string("unsupported sample type ") + spec.format.c_str() + " (use 8/16-bit unsigned or float)");
  }
  DecodedTexture t;
  t.width = spec.width;
  t.height = spec.height;
  const size_t count = size_t(t.width) * size_t(t.height);
  t.samples.resize(count);
  bool ok = false;
  // The first channel only, read in the file's own type so integers keep their exact values.
  if (base == OIIO::TypeDesc::UINT8) {
    std::vector<uint8_t> tmp(count);
    ok = in->read_image(0, 0, 0, 1, OIIO::TypeDesc::UINT8, tmp.data());
    for (size_t i = 0; i < count; ++i) t.samples[i] = uint16_t(tmp[i] * 257u);
  } else if (base == OIIO::TypeDesc::UINT16) {
    ok = in->read_image(0, 0, 0, 1, OIIO::TypeDesc::UINT16, t.samples.data());
  } else {
    std::vector<double> tmp(count);
    ok = in->read_image(0, 0, 0, 1, OIIO::TypeDesc::DOUBLE, tmp.data());
    for (size_t i = 0; ok && i < count; ++i) {
      auto v = from_float(tmp[i], name);
      if (!v.ok()) return v.error();
      t.samples[i] = v.value();
    }
  }
  if (!ok) {
    std::string why = in->geterror();
    return fail(ErrorCode::kCorrupt, name,
                "cannot read the texture's samples: " + (why.empty() ? "decoder error" : why));
  }
  in->close();
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
