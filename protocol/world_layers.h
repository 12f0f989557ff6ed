// A World's samples by layer row: the one place that binds each row of protocol/layer.h to
// World's per-layer entry points (read_coarse / read_detail, write_coarse / write_detail) and
// to the tile hashes, so code that holds a runtime Layer copies, compares and hashes samples
// without naming a layer.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "protocol/layer.h"
#include "protocol/tile_hash.h"
#include "protocol/world.h"

namespace loam {

template <class R>
struct LayerOps;
template <>
struct LayerOps<CoarseLayer> {
  static uint16_t sample(const World& w, int64_t x, int64_t y) { return w.coarse(x, y); }
  // Mip 0's tile (generated from the base where never edited; empty outside the world).
  static std::span<const uint16_t> tile(const World& w, int32_t tx, int32_t ty) {
    return w.coarse_tile(0, tx, ty);
  }
  static std::span<uint16_t> tile_mut(World& w, int32_t tx, int32_t ty) { return w.coarse_tile_mut(tx, ty); }
  static void read(const World& w, const RectI& r, std::span<uint16_t> out) { w.read_coarse(r, out); }
  static int64_t write(World& w, const RectI& r, std::span<const uint16_t> in) {
    return w.write_coarse(r, in);
  }
  static uint64_t hash(std::span<const uint16_t> tile) { return hash_coarse_tile(tile); }
};
template <>
struct LayerOps<DetailLayer> {
  static int8_t sample(const World& w, int64_t x, int64_t y) { return w.detail(x, y); }
  // Empty where the tile is not stored (all zero).
  static std::span<const int8_t> tile(const World& w, int32_t tx, int32_t ty) {
    return w.detail_tile(tx, ty);
  }
  static std::span<int8_t> tile_mut(World& w, int32_t tx, int32_t ty) { return w.detail_tile_mut(tx, ty); }
  static void read(const World& w, const RectI& r, std::span<int8_t> out) { w.read_detail(r, out); }
  static int64_t write(World& w, const RectI& r, std::span<const int8_t> in) { return w.write_detail(r, in); }
  // An unstored tile (empty span) is all zero.
  static uint64_t hash(std::span<const int8_t> tile) {
    return tile.empty() ? zero_detail_tile_hash() : hash_detail_tile(tile);
  }
};

// The samples of `r` (inside the row's layer), row-major.
template <class R>
std::vector<typename R::Sample> read_rect(const World& w, const RectI& r) {
  std::vector<typename R::Sample> out(size_t(r.area()));
  LayerOps<R>::read(w, r, out);
  return out;
}

// The samples of `r` of a layer as int32 (either layer), for comparisons.
inline std::vector<int32_t> read_rect_i32(const World& w, Layer layer, const RectI& r) {
  return visit_layer(layer, [&](auto row) {
    const auto s = read_rect<decltype(row)>(w, r);
    return std::vector<int32_t>(s.begin(), s.end());
  });
}

// Copies `r` of a layer from one world to another (same layer geometry over `r`); returns what
// write_coarse / write_detail return.
inline int64_t copy_rect(const World& from, World& to, Layer layer, const RectI& r) {
  return visit_layer(layer, [&](auto row) {
    using R = decltype(row);
    const auto s = read_rect<R>(from, r);
    return LayerOps<R>::write(to, r, s);
  });
}

}  // namespace loam
