#include "protocol/geometry.h"

#include <cmath>

namespace loam {

const char* to_string(Layer layer) {
  switch (layer) {
    case Layer::kCoarse: return "coarse";
    case Layer::kDetail: return "detail";
  }
  return "?";
}

std::string to_string(const TileCoord& c) {
  return std::string(to_string(c.layer)) + "/" + std::to_string(c.mip) + "/" + std::to_string(c.tx) + "," +
         std::to_string(c.ty);
}

namespace {

Status check_positive(double v, const char* field, double max) {
  if (!std::isfinite(v)) return make_error(ErrorCode::kNotFinite, field, "must be finite");
  if (!(v > 0.0)) return make_error(ErrorCode::kInvalidArgument, field, "must be > 0");
  if (v > max) {
    return make_error(ErrorCode::kInvalidArgument, field,
                      "must be <= " + std::to_string(max) + ", got " + std::to_string(v));
  }
  return {};
}

}  // namespace

Status WorldParams::validate() const {
  LOAM_TRY(check_positive(meters_per_sample, "meters_per_sample", 1.0e5));
  LOAM_TRY(check_positive(meters_per_unit, "meters_per_unit", 1.0e3));
  LOAM_TRY(check_positive(detail_meters_per_unit, "detail_meters_per_unit", 1.0e3));
  if (!std::isfinite(height_offset) || std::fabs(height_offset) > 1.0e7) {
    return make_error(ErrorCode::kInvalidArgument, "height_offset", "must be finite and within +-1e7 m");
  }
  if (detail_factor < 1 || detail_factor > 16 || (detail_factor & (detail_factor - 1)) != 0) {
    return make_error(ErrorCode::kInvalidArgument, "detail_factor",
                      "must be a power of two in 1..16, got " + std::to_string(detail_factor));
  }
  // Extent: at most 4096 x 4096 tiles (2^20 samples a side), and the whole detail grid must
  // stay inside int32 tile coordinates even far from the origin.
  if (tiles_x < 1 || tiles_x > 4096) {
    return make_error(ErrorCode::kInvalidArgument, "tiles_x", "must be in 1..4096");
  }
  if (tiles_y < 1 || tiles_y > 4096) {
    return make_error(ErrorCode::kInvalidArgument, "tiles_y", "must be in 1..4096");
  }
  constexpr int64_t kMaxOrigin = int64_t(1) << 26;  // detail tiles (x16) stay within int32
  if (std::llabs(int64_t(origin_tile_x)) > kMaxOrigin) {
    return make_error(ErrorCode::kInvalidArgument, "origin_tile_x", "must be within +-2^26");
  }
  if (std::llabs(int64_t(origin_tile_y)) > kMaxOrigin) {
    return make_error(ErrorCode::kInvalidArgument, "origin_tile_y", "must be within +-2^26");
  }
  return {};
}

int32_t WorldParams::mip_count() const {
  // Mips until one tile spans the whole world: then the world covers one tile when its origin
  // is aligned to that mip's tiles, and at most 2 x 2 otherwise.
  int32_t count = 1;
  while (count < kMaxMips &&
         (int64_t(kTileSize) << (count - 1)) < int64_t(std::max(tiles_x, tiles_y)) * kTileSize) {
    ++count;
  }
  return count;
}

RectI WorldParams::tile_range(int32_t mip) const {
  const RectI s = sample_rect();
  const int64_t span = int64_t(kTileSize) << mip;
  return {floor_div(s.x0, span), floor_div(s.y0, span), floor_div(s.x1 - 1, span) + 1,
          floor_div(s.y1 - 1, span) + 1};
}

uint16_t quantize_height(const WorldParams& p, double meters) {
  const double q = std::nearbyint((meters - p.height_offset) / p.meters_per_unit);
  if (!(q > 0.0)) return 0;  // also catches NaN
  if (q >= 65535.0) return 65535;
  return uint16_t(q);
}

RectI mip_samples_reaching(const WorldParams& p, int32_t mip, const RectI& rect0) {
  if (rect0.empty()) return {};
  const RectI world_samples = p.sample_rect();
  const RectI tiles = p.tile_range(mip);
  const RectI mip_samples = {tiles.x0 * kTileSize, tiles.y0 * kTileSize, tiles.x1 * kTileSize,
                             tiles.y1 * kTileSize};
  const int64_t step = int64_t(1) << mip;
  // Sample i reads mip-0 position clamp(i * step): inside rect0 from the first multiple of
  // step at or after x0 to the last one before x1, and everything past an edge rect0 touches.
  RectI r = {ceil_div(rect0.x0, step), ceil_div(rect0.y0, step), floor_div(rect0.x1 - 1, step) + 1,
             floor_div(rect0.y1 - 1, step) + 1};
  if (rect0.x0 <= world_samples.x0) r.x0 = mip_samples.x0;
  if (rect0.y0 <= world_samples.y0) r.y0 = mip_samples.y0;
  if (rect0.x1 >= world_samples.x1) r.x1 = mip_samples.x1;
  if (rect0.y1 >= world_samples.y1) r.y1 = mip_samples.y1;
  r = r.intersect(mip_samples);
  return r.empty() ? RectI{} : r;
}

}  // namespace loam
