#include "dem/dem_raster.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "dem/tiff_tags.h"

namespace loam {
namespace {

constexpr int64_t kMaxDemSide = int64_t(1) << 20;
constexpr int64_t kMaxDemSamples = int64_t(1) << 30;

Error fail(ErrorCode code, const std::string& name, const std::string& why) {
  return make_error(code, name, why);
}

Result<std::vector<uint8_t>> read_whole_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(ErrorCode::kNotFound, path, "cannot open the file");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) return fail(ErrorCode::kIo, path, "cannot determine the file size");
  if (size == 0) return fail(ErrorCode::kInvalidArgument, path, "the file is empty");
  in.seekg(0);
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  if (!in.read(reinterpret_cast<char*>(bytes.data()), size)) return fail(ErrorCode::kIo, path, "read failed");
  return bytes;
}

struct Sidecar {
  std::optional<double> meters_per_sample;
  double anisotropy = 1.0;
  std::optional<double> vertical_scale;
  std::optional<double> vertical_offset;
  std::optional<LoamSidecarWorld> loam_world;
};

Result<Sidecar> parse_sidecar(const std::string& text, const std::string& name) {
  Sidecar s;
  nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object())
    return fail(ErrorCode::kCorrupt, name, "sidecar JSON does not parse");
  auto number = [&](const nlohmann::json& o, const char* key) -> std::optional<double> {
    if (!o.contains(key) || !o[key].is_number()) return std::nullopt;
    const double v = o[key].get<double>();
    return std::isfinite(v) ? std::optional<double>(v) : std::nullopt;
  };
  if (j.contains("meters_per_sample_xy") && j["meters_per_sample_xy"].is_array() &&
      j["meters_per_sample_xy"].size() == 2 && j["meters_per_sample_xy"][0].is_number() &&
      j["meters_per_sample_xy"][1].is_number()) {
    const double x = j["meters_per_sample_xy"][0].get<double>(),
                 y = j["meters_per_sample_xy"][1].get<double>();
    if (std::isfinite(x) && std::isfinite(y) && x > 0 && y > 0) {
      // Loam's samples are square: use the geometric mean and report the anisotropy.
      s.meters_per_sample = std::sqrt(x * y);
      s.anisotropy = y / x;
    }
  } else if (auto m = number(j, "meters_per_sample")) {
    s.meters_per_sample = m;
  }
  s.vertical_scale = number(j, "height_scale_m");
  s.vertical_offset = number(j, "height_offset_m");
  if (j.contains("loam_world") && j["loam_world"].is_object()) {
    const auto& w = j["loam_world"];
    WorldParams p;
    auto need = [&](const char* key, double& out) {
      if (auto v = number(w, key)) {
        out = *v;
        return true;
      }
      return false;
    };
    double dfac = 0, otx = 0, oty = 0, tx = 0, ty = 0;
    if (need("meters_per_sample", p.meters_per_sample) && need("height_offset", p.height_offset) &&
        need("meters_per_unit", p.meters_per_unit) && need("detail_factor", dfac) &&
        need("detail_meters_per_unit", p.detail_meters_per_unit) && need("origin_tile_x", otx) &&
        need("origin_tile_y", oty) && need("tiles_x", tx) && need("tiles_y", ty)) {
      p.detail_factor = int32_t(dfac);
      p.origin_tile_x = int32_t(otx);
      p.origin_tile_y = int32_t(oty);
      p.tiles_x = int32_t(tx);
      p.tiles_y = int32_t(ty);
      const Status st = p.validate();
      if (!st.ok()) return fail(ErrorCode::kCorrupt, name, "sidecar loam_world: " + st.error().describe());
      s.loam_world = LoamSidecarWorld{p};
    } else {
      return fail(ErrorCode::kCorrupt, name, "sidecar loam_world lacks a field");
    }
  }
  return s;
}

std::string sidecar_path(const std::string& path) {
  const size_t dot = path.find_last_of('.');
  const size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return path + ".json";
  return path.substr(0, dot) + ".json";
}

Result<DemRaster> decode(std::span<const uint8_t> bytes, const std::string& name,
                         const std::string& sidecar_json, const DemScaleOptions& options) {
  std::string ext = OIIO::Filesystem::extension(name, false);
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext.empty()) return fail(ErrorCode::kUnsupported, name, "no file extension to tell the format");
  if (ext != "png" && ext != "tif" && ext != "tiff" && ext != "exr") {
    return fail(ErrorCode::kUnsupported, name, "unsupported format '" + ext + "' (use PNG, TIFF or EXR)");
  }
  OIIO::Filesystem::IOMemReader proxy(const_cast<uint8_t*>(bytes.data()), bytes.size());
  OIIO::ImageSpec spec;
  auto in = OIIO::ImageInput::create(ext);
  if (!in || !in->set_ioproxy(&proxy) || !in->open(name, spec)) {
    std::string why = in ? in->geterror() : OIIO::geterror();
    if (why.empty()) why = "not a readable image";
    return fail(ErrorCode::kCorrupt, name, "cannot decode: " + why);
  }
  spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) {
    return fail(ErrorCode::kCorrupt, name, "image has no samples");
  }
  if (spec.width < 2 || spec.height < 2) {
    return fail(ErrorCode::kInvalidArgument, name,
                "image is " + std::to_string(spec.width) + "x" + std::to_string(spec.height) +
                    "; a DEM needs at least 2x2 samples");
  }
  if (spec.width > kMaxDemSide || spec.height > kMaxDemSide ||
      int64_t(spec.width) * spec.height > kMaxDemSamples) {
    return fail(ErrorCode::kOversize, name, "image is larger than 2^30 samples");
  }
  const OIIO::TypeDesc fmt = spec.format;
  DemRaster dem;
  dem.name = name;
  dem.width = spec.width;
  dem.height = spec.height;
  const auto base = OIIO::TypeDesc::BASETYPE(fmt.basetype);
  dem.integer_source =
      base == OIIO::TypeDesc::UINT8 || base == OIIO::TypeDesc::UINT16 || base == OIIO::TypeDesc::INT16;
  const bool float_source =
      base == OIIO::TypeDesc::FLOAT || base == OIIO::TypeDesc::HALF || base == OIIO::TypeDesc::DOUBLE;
  if (!dem.integer_source && !float_source) {
    return fail(ErrorCode::kUnsupported, name,
                std::string("unsupported sample type ") + fmt.c_str() + " (use 8/16-bit integer or float)");
  }
  // Read the first channel in the source's own type, so integers keep their exact values.
  const size_t count = size_t(spec.width) * size_t(spec.height);
  std::vector<double> raw(count);
  bool ok = false;
  auto read_as = [&](auto tag, OIIO::TypeDesc type) {
    std::vector<decltype(tag)> tmp(count);
    ok = in->read_image(0, 0, 0, 1, type, tmp.data());
    for (size_t i = 0; i < count; ++i) raw[i] = double(tmp[i]);
  };
  if (base == OIIO::TypeDesc::UINT8)
    read_as(uint8_t{}, OIIO::TypeDesc::UINT8);
  else if (base == OIIO::TypeDesc::UINT16)
    read_as(uint16_t{}, OIIO::TypeDesc::UINT16);
  else if (base == OIIO::TypeDesc::INT16)
    read_as(int16_t{}, OIIO::TypeDesc::INT16);
  else
    read_as(float{}, OIIO::TypeDesc::FLOAT);
  if (!ok) {
    std::string why = in->geterror();
    return fail(ErrorCode::kCorrupt, name,
                "cannot read the samples: " + (why.empty() ? std::string("decoder error") : why));
  }
  in->close();

  // Scale: explicit > sidecar > GeoTIFF > defaults.
  Sidecar side;
  if (!sidecar_json.empty()) {
    auto parsed = parse_sidecar(sidecar_json, name + " sidecar");
    if (!parsed) return parsed.error();
    side = *parsed;
  }
  TiffGeoTags geo;
  if (ext == "tif" || ext == "tiff") {
    auto tags = read_tiff_geo_tags(bytes);
    if (!tags) return fail(ErrorCode::kCorrupt, name, tags.error().describe());
    geo = *tags;
  }
  dem.scale_source = "default";
  if (options.meters_per_sample) {
    dem.meters_per_sample = *options.meters_per_sample;
    dem.scale_source = "explicit";
  } else if (side.meters_per_sample) {
    dem.meters_per_sample = *side.meters_per_sample;
    dem.anisotropy = side.anisotropy;
    dem.scale_source = "sidecar";
  } else if (geo.pixel_scale_x && geo.pixel_scale_y && *geo.pixel_scale_x > 0 && *geo.pixel_scale_y > 0) {
    dem.meters_per_sample = std::sqrt(*geo.pixel_scale_x * *geo.pixel_scale_y);
    dem.anisotropy = *geo.pixel_scale_y / *geo.pixel_scale_x;
    dem.scale_source = "geotiff";
  }
  if (!std::isfinite(dem.meters_per_sample) || dem.meters_per_sample <= 0 || dem.meters_per_sample > 1e5) {
    return fail(ErrorCode::kInvalidArgument, name, "meters per sample must be in (0, 1e5]");
  }
  double scale = 1.0, offset = 0.0;
  if (dem.integer_source) {
    if (side.vertical_scale) scale = *side.vertical_scale;
    if (side.vertical_offset) offset = *side.vertical_offset;
    if (options.vertical_scale) scale = *options.vertical_scale;
    if (options.vertical_offset) offset = *options.vertical_offset;
    if (!std::isfinite(scale) || scale <= 0 || !std::isfinite(offset)) {
      return fail(ErrorCode::kInvalidArgument, name, "vertical scale must be finite and > 0");
    }
    dem.vertical_step = scale;
  } else if (options.vertical_scale || options.vertical_offset) {
    scale = options.vertical_scale.value_or(1.0);
    offset = options.vertical_offset.value_or(0.0);
  }
  dem.loam_world = side.loam_world;

  dem.meters.resize(count);
  const std::optional<double> nodata = geo.nodata;
  for (size_t i = 0; i < count; ++i) {
    const double v = raw[i];
    const bool missing =
        !std::isfinite(v) || (nodata && (v == *nodata || (std::isnan(*nodata) && std::isnan(v))));
    if (missing) {
      dem.meters[i] = std::numeric_limits<double>::quiet_NaN();
      ++dem.nodata_count;
    } else {
      dem.meters[i] = offset + scale * v;
    }
  }
  if (dem.nodata_count == int64_t(count)) {
    return fail(ErrorCode::kInvalidArgument, name, "every sample is NaN or NoData");
  }
  return dem;
}

}  // namespace

Result<DemRaster> read_dem_file(const std::string& path, const DemScaleOptions& options) {
  auto bytes = read_whole_file(path);
  if (!bytes) return bytes.error();
  std::string sidecar;
  const std::string side = sidecar_path(path);
  if (side != path) {
    std::ifstream in(side);
    if (in) {
      std::ostringstream text;
      text << in.rdbuf();
      sidecar = text.str();
    }
  }
  auto dem = decode(*bytes, path, sidecar, options);
  if (!dem) return dem.error();
  return dem;
}

Result<DemRaster> read_dem_memory(std::span<const uint8_t> bytes, const std::string& name,
                                  const std::string& sidecar_json, const DemScaleOptions& options) {
  if (bytes.empty()) return fail(ErrorCode::kInvalidArgument, name, "the image is empty");
  return decode(bytes, name, sidecar_json, options);
}

}  // namespace loam
