// Copying a rectangle of samples out of one tile: what a partial region sends (the server)
// and what a delta-coded partial region is decoded against (the client). Pure: no I/O.
#pragma once

#include <algorithm>
#include <cstddef>
#include <span>
#include <vector>

#include "protocol/geometry.h"

namespace loam {

// The samples of `rect` (tile-local: inside [0, kTileSize)^2) of a row-major
// kTileSize x kTileSize tile, row by row. A tile that is not stored (an empty span: a detail
// tile that is all zero) yields rect.area() zeros. A rect outside the tile, or a tile of any
// other size, yields an empty vector; the caller decides whether that is an error. Safe on
// any input: it never reads outside `tile`.
template <typename T>
std::vector<T> copy_tile_rect(std::span<const T> tile, const RectI& rect) {
  if (!RectI{0, 0, kTileSize, kTileSize}.contains(rect)) return {};
  if (tile.empty()) return std::vector<T>(size_t(rect.area()), T{});
  if (tile.size() != size_t(kTileSamples)) return {};
  std::vector<T> out;
  out.reserve(size_t(rect.area()));
  for (int64_t y = rect.y0; y < rect.y1; ++y) {
    const auto row = tile.begin() + (y * kTileSize);
    out.insert(out.end(), row + rect.x0, row + rect.x1);
  }
  return out;
}

}  // namespace loam
