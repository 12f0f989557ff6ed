#include "dem/dem_export.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <span>
#include <vector>

#include "dem/image_file.h"

namespace loam {
namespace {

Status check_region(const World& world, const RectI& region, const std::string& path) {
  if (region.empty() || !world.params().sample_rect().contains(region)) {
    return make_error(ErrorCode::kInvalidArgument, path, "export region is empty or outside the world");
  }
  return {};
}

}  // namespace

std::string sidecar_json(const WorldParams& p, const RectI& region) {
  nlohmann::json j;
  j["name"] = "loam export";
  j["width"] = region.width();
  j["height"] = region.height();
  j["sample_type"] = "uint16";
  j["height_m_formula"] = "height_m = height_offset_m + height_scale_m * value";
  j["height_offset_m"] = p.height_offset;
  j["height_scale_m"] = p.meters_per_unit;
  j["meters_per_sample_xy"] = {p.meters_per_sample, p.meters_per_sample};
  j["region_global_samples"] = {region.x0, region.y0, region.x1, region.y1};
  nlohmann::json w;
  w["meters_per_sample"] = p.meters_per_sample;
  w["height_offset"] = p.height_offset;
  w["meters_per_unit"] = p.meters_per_unit;
  w["detail_factor"] = p.detail_factor;
  w["detail_meters_per_unit"] = p.detail_meters_per_unit;
  // A whole-world export re-imports at the same origin; a region becomes its own world.
  const bool whole = region == p.sample_rect();
  w["origin_tile_x"] = whole ? p.origin_tile_x : 0;
  w["origin_tile_y"] = whole ? p.origin_tile_y : 0;
  w["tiles_x"] = ceil_div(region.width(), kTileSize);
  w["tiles_y"] = ceil_div(region.height(), kTileSize);
  j["loam_world"] = w;
  return j.dump(1) + "\n";
}

Status export_png16(const World& world, const RectI& region, const std::string& path) {
  LOAM_TRY(check_region(world, region, path));
  std::vector<uint16_t> px(size_t(region.area()));
  world.read_coarse(region, px);
  LOAM_TRY(write_image_file(
      path, image_view(int32_t(region.width()), int32_t(region.height()), 1, std::span<const uint16_t>(px))));
  const size_t dot = path.find_last_of('.');
  const std::string side = (dot == std::string::npos ? path : path.substr(0, dot)) + ".json";
  std::ofstream out(side);
  out << sidecar_json(world.params(), region);
  if (!out) return make_error(ErrorCode::kIo, side, "cannot write the sidecar");
  return {};
}

Status export_exr(const World& world, const RectI& region, const std::string& path) {
  LOAM_TRY(check_region(world, region, path));
  const WorldParams& p = world.params();
  std::vector<float> px(size_t(region.area()));
  const int64_t k = p.detail_factor;
  for (int64_t y = region.y0; y < region.y1; ++y) {
    for (int64_t x = region.x0; x < region.x1; ++x) {
      double h = p.height_meters(world.coarse(x, y));
      if (world.detail_tile_count() != 0) h += p.detail_meters(world.detail(x * k, y * k));
      px[size_t((y - region.y0) * region.width() + (x - region.x0))] = float(h);
    }
  }
  return write_image_file(
      path, image_view(int32_t(region.width()), int32_t(region.height()), 1, std::span<const float>(px)));
}

}  // namespace loam
