#include "protocol/base/tile_row_pyramid.h"

#include <algorithm>

namespace loam {

TileRowPyramid::TileRowPyramid(const WorldParams& params, Sink sink)
    : samples_(params.sample_rect()), next_y_(samples_.y0), tile_(kTileSamples), sink_(std::move(sink)) {
  const int32_t mips = params.mip_count();
  levels_.resize(size_t(mips));
  for (int32_t m = 0; m < mips; ++m) {
    Level& l = levels_[size_t(m)];
    l.tiles = params.tile_range(m);
    l.tile_row = l.tiles.y0;
    const int64_t width = l.tiles.width() * kTileSize;
    l.column.resize(size_t(width));
    for (int64_t i = 0; i < width; ++i) {
      const int64_t gx = (l.tiles.x0 * kTileSize + i) << m;
      l.column[size_t(i)] = int32_t(std::clamp(gx, samples_.x0, samples_.x1 - 1) - samples_.x0);
    }
    l.rows.resize(size_t(width * kTileSize));
  }
}

size_t TileRowPyramid::buffer_bytes() const {
  size_t n = tile_.size() * sizeof(uint16_t);
  for (const Level& l : levels_) n += l.rows.size() * sizeof(uint16_t) + l.column.size() * sizeof(int32_t);
  return n;
}

Status TileRowPyramid::flush(int32_t mip, Level& l) {
  const int64_t width = l.tiles.width() * kTileSize;
  for (int64_t tx = l.tiles.x0; tx < l.tiles.x1; ++tx) {
    const int64_t x0 = (tx - l.tiles.x0) * kTileSize;
    for (int32_t j = 0; j < kTileSize; ++j) {
      const uint16_t* src = l.rows.data() + size_t(j * width + x0);
      std::copy(src, src + kTileSize, tile_.begin() + ptrdiff_t(j) * kTileSize);
    }
    LOAM_TRY(sink_(mip, int32_t(tx), int32_t(l.tile_row), tile_));
  }
  ++l.tile_row;
  return {};
}

Status TileRowPyramid::add_row(std::span<const uint16_t> row) {
  if (done()) return make_error(ErrorCode::kInvalidArgument, "pyramid.row", "every row was already given");
  if (row.size() != size_t(samples_.width()))
    return make_error(ErrorCode::kInvalidArgument, "pyramid.row", "a row must span the world's width");
  const int64_t y = next_y_++;
  for (size_t m = 0; m < levels_.size(); ++m) {
    Level& l = levels_[m];
    if (l.tile_row >= l.tiles.y1) continue;
    const int64_t step = int64_t(1) << m;
    const int64_t first = l.tile_row * kTileSize, last = first + kTileSize - 1;
    // Mip rows gy reading this mip-0 row: gy * step == y, and every row clamped onto it at the
    // world's top and bottom edges.
    int64_t lo = ceil_div(y, step), hi = floor_div(y, step);
    if (y == samples_.y0) lo = first;
    if (y == samples_.y1 - 1) hi = last;
    lo = std::max(lo, first);
    hi = std::min(hi, last);
    const int64_t width = l.tiles.width() * kTileSize;
    for (int64_t gy = lo; gy <= hi; ++gy) {
      uint16_t* dst = l.rows.data() + size_t((gy - first) * width);
      for (int64_t i = 0; i < width; ++i) dst[i] = row[size_t(l.column[size_t(i)])];
    }
    // The tile row is complete once the mip-0 row its last row reads has arrived.
    if (std::clamp(last * step, samples_.y0, samples_.y1 - 1) <= y) LOAM_TRY(flush(int32_t(m), l));
  }
  return {};
}

}  // namespace loam
