// World geometry: the integer grid every party agrees on.
//
// Samples live on a global integer grid (int64, signed); tiles of kTileSize x kTileSize
// samples are addressed by signed tile coordinates; a mip-m tile holds every 2^m-th
// full-resolution sample (decimation), so its samples coincide with mip-0 samples. The
// coarse layer stores uint16 heights, the detail layer int8 offsets on a grid k times finer.
// Everything here is pure arithmetic: no I/O, safe on any input.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>

#include "protocol/result.h"

namespace loam {

inline constexpr int32_t kTileSize = 256;
inline constexpr int32_t kTileShift = 8;
inline constexpr int32_t kTileSamples = kTileSize * kTileSize;
inline constexpr int32_t kMaxMips = 16;

enum class Layer : uint8_t { kCoarse = 0, kDetail = 1 };
const char* to_string(Layer layer);

// Floor division and modulo for signed coordinates (C++ '/' truncates toward zero).
constexpr int64_t floor_div(int64_t a, int64_t b) {
  const int64_t q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}
constexpr int64_t floor_mod(int64_t a, int64_t b) { return a - floor_div(a, b) * b; }
constexpr int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }

// Half-open integer rectangle [x0, x1) x [y0, y1).
struct RectI {
  int64_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;

  int64_t width() const { return x1 - x0; }
  int64_t height() const { return y1 - y0; }
  int64_t area() const { return empty() ? 0 : width() * height(); }
  bool empty() const { return x1 <= x0 || y1 <= y0; }
  bool contains(int64_t x, int64_t y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
  bool contains(const RectI& r) const {
    return r.empty() || (r.x0 >= x0 && r.x1 <= x1 && r.y0 >= y0 && r.y1 <= y1);
  }
  RectI intersect(const RectI& r) const {
    return {std::max(x0, r.x0), std::max(y0, r.y0), std::min(x1, r.x1), std::min(y1, r.y1)};
  }
  // Smallest rect holding both; an empty operand is ignored.
  RectI unite(const RectI& r) const {
    if (empty()) return r;
    if (r.empty()) return *this;
    return {std::min(x0, r.x0), std::min(y0, r.y0), std::max(x1, r.x1), std::max(y1, r.y1)};
  }
  RectI translated(int64_t dx, int64_t dy) const { return {x0 + dx, y0 + dy, x1 + dx, y1 + dy}; }
  friend bool operator==(const RectI&, const RectI&) = default;
};

// Address of one tile: layer, mip level and signed tile coordinates at that mip.
struct TileCoord {
  Layer layer = Layer::kCoarse;
  uint8_t mip = 0;
  int32_t tx = 0;
  int32_t ty = 0;

  friend bool operator==(const TileCoord&, const TileCoord&) = default;
  friend auto operator<=>(const TileCoord&, const TileCoord&) = default;
};
std::string to_string(const TileCoord& c);

struct TileCoordHash {
  size_t operator()(const TileCoord& c) const {
    uint64_t k = (uint64_t(uint32_t(c.tx)) << 32) | uint32_t(c.ty);
    k ^= (uint64_t(c.mip) << 56) ^ (uint64_t(c.layer) << 63);
    k *= 0x9E3779B97F4A7C15ull;
    return size_t(k ^ (k >> 29));
  }
};

// Sample rect covered by tile c in its own mip's sample grid (mip-m sample i sits at
// full-resolution sample i * 2^m).
inline RectI tile_rect(int32_t tx, int32_t ty) {
  return {int64_t(tx) * kTileSize, int64_t(ty) * kTileSize, int64_t(tx + 1) * kTileSize,
          int64_t(ty + 1) * kTileSize};
}

// Range of tiles [tx0, tx1) x [ty0, ty1) overlapping a sample rect (in one grid).
inline RectI tiles_overlapping(const RectI& samples) {
  if (samples.empty()) return {};
  return {floor_div(samples.x0, kTileSize), floor_div(samples.y0, kTileSize),
          floor_div(samples.x1 - 1, kTileSize) + 1, floor_div(samples.y1 - 1, kTileSize) + 1};
}

// Parameters fixed for the life of a world; they travel in Welcome and in log headers.
struct WorldParams {
  double meters_per_sample = 1.0;         // horizontal spacing of coarse samples
  double height_offset = 0.0;             // meters at coarse value 0
  double meters_per_unit = 1.0 / 64.0;    // meters per coarse height unit
  int32_t detail_factor = 4;              // detail samples per coarse sample (power of two)
  double detail_meters_per_unit = 0.005;  // meters per detail unit
  int32_t origin_tile_x = 0;              // mip-0 tile coordinates of the first tile
  int32_t origin_tile_y = 0;
  int32_t tiles_x = 1;  // world extent in mip-0 tiles
  int32_t tiles_y = 1;

  // Checks every field against its documented range; the error names the field.
  Status validate() const;

  // Global coarse sample rect of the whole world.
  RectI sample_rect() const {
    return {int64_t(origin_tile_x) * kTileSize, int64_t(origin_tile_y) * kTileSize,
            (int64_t(origin_tile_x) + tiles_x) * kTileSize, (int64_t(origin_tile_y) + tiles_y) * kTileSize};
  }
  // Global detail sample rect of the whole world.
  RectI detail_sample_rect() const {
    const RectI r = sample_rect();
    return {r.x0 * detail_factor, r.y0 * detail_factor, r.x1 * detail_factor, r.y1 * detail_factor};
  }
  // Number of coarse mips: mip 0 up to the first level whose tile spans the whole world.
  int32_t mip_count() const;
  // Tile range [tx0, tx1) x [ty0, ty1) of the coarse world at a mip.
  RectI tile_range(int32_t mip) const;

  double height_meters(uint16_t q) const { return height_offset + double(q) * meters_per_unit; }
  double detail_meters(int8_t d) const { return double(d) * detail_meters_per_unit; }
  double detail_meters_per_sample() const { return meters_per_sample / detail_factor; }

  friend bool operator==(const WorldParams&, const WorldParams&) = default;
};

// Nearest-integer height unit for a height in meters, saturated to 0..65535.
uint16_t quantize_height(const WorldParams& p, double meters);

// The samples of coarse mip `mip` (its global sample grid, inside the mip's tile range) whose
// values are mip-0 samples in `rect0`: sample i is mip-0 sample clamp(i * 2^m), so a rect
// touching the world's edge also reaches every mip sample beyond that edge. Empty if none.
RectI mip_samples_reaching(const WorldParams& p, int32_t mip, const RectI& rect0);

}  // namespace loam
