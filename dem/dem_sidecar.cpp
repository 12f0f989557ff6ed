#include "dem/dem_sidecar.h"

#include <cmath>
#include <nlohmann/json.hpp>

namespace loam {
namespace {

Error corrupt(const std::string& name, const std::string& why) {
  return make_error(ErrorCode::kCorrupt, name, why);
}

// A key that is present must be a finite number.
Result<std::optional<double>> number(const nlohmann::json& o, const char* key, const std::string& name) {
  if (!o.contains(key) || o[key].is_null()) return std::optional<double>{};
  if (!o[key].is_number()) return corrupt(name, std::string("'") + key + "' is not a number");
  const double v = o[key].get<double>();
  if (!std::isfinite(v)) return corrupt(name, std::string("'") + key + "' is not finite");
  return std::optional<double>(v);
}

Result<std::optional<int64_t>> dimension(const nlohmann::json& o, const char* key, const std::string& name) {
  auto v = number(o, key, name);
  if (!v) return v.error();
  if (!*v) return std::optional<int64_t>{};
  const double d = **v;
  if (d < 1 || d > double(int64_t(1) << 40) || d != std::floor(d))
    return corrupt(name, std::string("'") + key + "' is not a positive whole number");
  return std::optional<int64_t>(int64_t(d));
}

std::string canonical_type(std::string t) {
  for (char& c : t) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (t == "float" || t == "single") return "float32";
  if (t == "double") return "float64";
  if (t == "half") return "float16";
  if (t == "byte") return "uint8";
  return t;
}

}  // namespace

Result<Sidecar> parse_sidecar(const std::string& text, const std::string& name) {
  Sidecar s;
  nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return corrupt(name, "sidecar JSON does not parse");
  if (j.contains("meters_per_sample_xy") && !j["meters_per_sample_xy"].is_null()) {
    const auto& xy = j["meters_per_sample_xy"];
    if (!xy.is_array() || xy.size() != 2 || !xy[0].is_number() || !xy[1].is_number())
      return corrupt(name, "'meters_per_sample_xy' is not two numbers");
    const double x = xy[0].get<double>(), y = xy[1].get<double>();
    // The range a DEM's spacing may take (dem_raster.h), so the mean and the ratio stay finite.
    if (!(x >= 1e-6 && x <= 1e5 && y >= 1e-6 && y <= 1e5))
      return corrupt(name, "'meters_per_sample_xy' must be two spacings in [1e-6, 1e5] m");
    // Loam's samples are square: use the geometric mean and report the anisotropy.
    s.meters_per_sample = std::sqrt(x * y);
    s.anisotropy = y / x;
  } else {
    auto m = number(j, "meters_per_sample", name);
    if (!m) return m.error();
    if (*m && !(**m > 0 && **m <= 1e5)) return corrupt(name, "'meters_per_sample' must be in (0, 1e5]");
    s.meters_per_sample = *m;
  }
  auto scale = number(j, "height_scale_m", name);
  if (!scale) return scale.error();
  s.vertical_scale = *scale;
  auto offset = number(j, "height_offset_m", name);
  if (!offset) return offset.error();
  s.vertical_offset = *offset;
  auto w = dimension(j, "width", name);
  if (!w) return w.error();
  s.width = *w;
  auto h = dimension(j, "height", name);
  if (!h) return h.error();
  s.height = *h;
  if (j.contains("sample_type") && !j["sample_type"].is_null()) {
    if (!j["sample_type"].is_string()) return corrupt(name, "'sample_type' is not a string");
    s.sample_type = canonical_type(j["sample_type"].get<std::string>());
  }
  if (j.contains("loam_world") && j["loam_world"].is_object()) {
    const auto& lw = j["loam_world"];
    WorldParams p;
    double dfac = 0, otx = 0, oty = 0, tx = 0, ty = 0;
    struct Key {
      const char* key;
      double* out;
    };
    const Key keys[] = {{"meters_per_sample", &p.meters_per_sample},
                        {"height_offset", &p.height_offset},
                        {"meters_per_unit", &p.meters_per_unit},
                        {"detail_factor", &dfac},
                        {"detail_meters_per_unit", &p.detail_meters_per_unit},
                        {"origin_tile_x", &otx},
                        {"origin_tile_y", &oty},
                        {"tiles_x", &tx},
                        {"tiles_y", &ty}};
    for (const Key& k : keys) {
      auto v = number(lw, k.key, name);
      if (!v) return v.error();
      if (!*v) return corrupt(name, std::string("sidecar loam_world lacks a field: ") + k.key);
      *k.out = **v;
    }
    for (double v : {dfac, otx, oty, tx, ty}) {
      if (v != std::floor(v) || std::fabs(v) > 1e9)
        return corrupt(name, "sidecar loam_world: not an integer");
    }
    p.detail_factor = int32_t(dfac);
    p.origin_tile_x = int32_t(otx);
    p.origin_tile_y = int32_t(oty);
    p.tiles_x = int32_t(tx);
    p.tiles_y = int32_t(ty);
    const Status st = p.validate();
    if (!st.ok()) return corrupt(name, "sidecar loam_world: " + st.error().describe());
    s.loam_world = LoamSidecarWorld{p};
  } else if (j.contains("loam_world") && !j["loam_world"].is_null()) {
    return corrupt(name, "'loam_world' is not an object");
  }
  return s;
}

Status check_sidecar_matches(const Sidecar& s, int64_t width, int64_t height, const std::string& sample_type,
                             const std::string& name) {
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  if ((s.width && *s.width != width) || (s.height && *s.height != height)) {
    return make_error(ErrorCode::kInvalidArgument, name,
                      "sidecar says " + std::to_string(s.width.value_or(width)) + "x" +
                          std::to_string(s.height.value_or(height)) + " samples but the image is " + size +
                          ": the sidecar describes another file");
  }
  if (s.sample_type && *s.sample_type != canonical_type(sample_type)) {
    return make_error(ErrorCode::kInvalidArgument, name,
                      "sidecar says sample_type " + *s.sample_type + " but the image holds " + sample_type);
  }
  if (s.loam_world) {
    const WorldParams& p = s.loam_world->params;
    const int64_t tx = (width + kTileSize - 1) / kTileSize, ty = (height + kTileSize - 1) / kTileSize;
    if (p.tiles_x != tx || p.tiles_y != ty) {
      return make_error(ErrorCode::kInvalidArgument, name,
                        "sidecar loam_world has " + std::to_string(p.tiles_x) + "x" +
                            std::to_string(p.tiles_y) + " tiles but the " + size + " image needs " +
                            std::to_string(tx) + "x" + std::to_string(ty));
    }
  }
  return {};
}

}  // namespace loam
