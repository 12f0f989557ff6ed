#include "dem/refined_default.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <span>
#include <vector>

#include "dem/default_terrain.h"

namespace loam {

namespace {

constexpr int32_t kLevels = 7;  // 128 m of world per crop sample
// Vertical scale at 1/32 m per height unit: land 1/8 (4 units per source metre) and the sea
// floor 1/32 (1 unit), so the Himalaya stand out and the trenches fit in 16 bits.
constexpr int32_t kLandUnitsPerSourceMeter = 4;
constexpr int32_t kSeaUnitsPerSourceMeter = 1;
constexpr double kMetersPerUnit = 1.0 / 32.0;
constexpr int32_t kEtopoZero = 10376;  // ETOPO5 value of sea level (source value 0 = -10376 m)

}  // namespace

RefinementParams default_refinement_params() {
  RefinementParams p;
  p.levels = kLevels;
  p.seed = 0x4c6f616d52656631ull;  // "LoamRef1"
  // Amplitudes for roughness 1.0 in 1/512 m (1/16 unit): a standard deviation of about
  // 0.12 m * s^0.9 for samples inserted at spacing s = 2^L m (fractional Brownian surface,
  // Hurst exponent 0.9), the triangular variate's deviation being amplitude / sqrt(6).
  p.amplitude = {150, 281, 524, 978, 1830, 3410, 6360, 0, 0, 0, 0, 0};
  // Roughness follows the crop's local relief (height units over 3x3 crop samples): about
  // 0.3 on plains and the abyssal floor, up to 2.5 on the Himalayan front.
  p.roughness_base = 64;
  p.roughness_gain = 24;
  p.roughness_max = 640;
  return p;
}

Result<RefinedWorld> load_refined_default() {
  auto dem = read_default_terrain_raster();
  if (!dem) return dem.error();
  // The sidecar maps ETOPO5 values v to game meters as -207.52 + 0.02 v; recover v exactly.
  const double offset = -207.52, scale = 0.02;
  std::vector<int32_t> etopo(dem->meters.size());
  int32_t vmin = INT32_MAX, vmax = INT32_MIN;
  for (size_t i = 0; i < etopo.size(); ++i) {
    const double v = (dem->meters[i] - offset) / scale;
    const double r = std::nearbyint(v);
    if (!std::isfinite(v) || std::abs(v - r) > 1e-3)
      return make_error(ErrorCode::kCorrupt, "default_terrain.png",
                        "a sample is not an ETOPO5 integer value");
    etopo[i] = int32_t(r);
    vmin = std::min(vmin, etopo[i]);
    vmax = std::max(vmax, etopo[i]);
  }
  // Units above the deepest sample; then centre the data's range in the 16-bit height range:
  // the rest is headroom for digging and building, and for the refinement's displacements.
  const auto units = [&](int32_t v) {
    const int32_t sea = std::max(0, std::min(v, kEtopoZero) - vmin) * kSeaUnitsPerSourceMeter;
    return sea + std::max(0, v - std::max(vmin, kEtopoZero)) * kLandUnitsPerSourceMeter;
  };
  const int32_t span = units(vmax);
  const int32_t headroom = (65536 - span) / 2;
  if (headroom < 4096)
    return make_error(ErrorCode::kCorrupt, "default_terrain.png",
                      "the crop's relief leaves no height headroom");
  std::vector<int32_t> source(etopo.size());
  for (size_t i = 0; i < etopo.size(); ++i) source[i] = units(etopo[i]) + headroom;

  RefinedWorld w{};
  auto base =
      RefinedBase::create(int32_t(dem->width), int32_t(dem->height), source, default_refinement_params());
  if (!base) return base.error();
  w.base = std::move(*base);
  w.params.meters_per_sample = 1.0;
  w.params.meters_per_unit = kMetersPerUnit;
  // Sea level at 0 m.
  w.params.height_offset = -double(units(kEtopoZero) + headroom) * kMetersPerUnit;
  w.params.detail_factor = 4;
  w.params.detail_meters_per_unit = kMetersPerUnit / 4.0;
  w.params.tiles_x = int32_t(w.base.width() / kTileSize);
  w.params.tiles_y = int32_t(w.base.height() / kTileSize);
  LOAM_TRY(w.params.validate());
  w.description =
      "the embedded ETOPO5 crop (Himalaya, Tibet, the Bay of Bengal) refined 128x: 131 x 98 km at 1 m, "
      "vertical scale 1/8 on land and 1/32 under the sea (1/32 m per height unit)";
  return w;
}

namespace {

struct DefaultBase {
  std::once_flag once;
  Result<std::shared_ptr<const RefinedTileBase>> base = make_error(ErrorCode::kNotFound, "base", "not built");
  WorldParams params;
};

DefaultBase& default_base() {
  static DefaultBase d;
  std::call_once(d.once, [] {
    auto rw = load_refined_default();
    if (!rw) {
      d.base = rw.error();
      return;
    }
    d.params = rw->params;
    d.base = RefinedTileBase::create(std::move(rw->base), rw->params);
  });
  return d;
}

}  // namespace

Result<std::shared_ptr<const RefinedTileBase>> refined_default_base() { return default_base().base; }

const WorldParams& refined_default_params() { return default_base().params; }

Result<std::shared_ptr<const TileBase>> known_base(uint64_t identity) {
  auto fill = std::make_shared<FillBase>(0);
  if (identity == fill->identity()) return std::shared_ptr<const TileBase>(std::move(fill));
  auto refined = refined_default_base();
  if (!refined) return refined.error();
  if ((*refined)->identity() == identity) return std::shared_ptr<const TileBase>(*refined);
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", (unsigned long long)identity);
  return make_error(ErrorCode::kNotFound, "base",
                    std::string("no base this program can generate has identity ") + buf +
                        " (a fill of 0 or the refined default of this version)");
}

std::shared_ptr<const TileBase> generate_known_base(uint64_t identity) {
  auto b = known_base(identity);
  return b ? *b : nullptr;
}

}  // namespace loam
