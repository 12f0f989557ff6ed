// TileRowPyramid: turns a world's mip-0 rows, given in order, into its coarse tiles at every
// mip, holding one tile row per mip and never the world. This is how a DEM of any size becomes
// a tile pack in bounded memory (dem/pack_import.h): about 2 x 256 rows of the world's width.
//
// The mips follow World's rule: mip-m sample i is mip-0 sample clamp(i * 2^m) in the world's
// sample rect, so a mip tile reaching past an edge repeats the edge samples. A tile is handed
// to the sink as soon as every mip-0 row it reads has arrived. Pure logic: no I/O.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam {

class TileRowPyramid {
 public:
  // Receives each tile (kTileSamples samples, row-major) once; an error stops the pyramid.
  using Sink = std::function<Status(int32_t mip, int32_t tx, int32_t ty, std::span<const uint16_t> samples)>;
  TileRowPyramid(const WorldParams& params, Sink sink);

  // The next mip-0 row of the world (params.sample_rect().width() samples), north first.
  Status add_row(std::span<const uint16_t> row);
  // Rows still expected, and whether every tile of every mip was handed over.
  int64_t rows_left() const { return samples_.y1 - next_y_; }
  bool done() const { return next_y_ == samples_.y1; }
  // Bytes held for the tile rows in progress.
  size_t buffer_bytes() const;

 private:
  struct Level {
    RectI tiles;                  // tile range at this mip
    int64_t tile_row = 0;         // the tile row being filled
    std::vector<int32_t> column;  // per sample of a row: the mip-0 column (rect-relative) it reads
    std::vector<uint16_t> rows;   // kTileSize rows of tiles.width() * kTileSize samples
  };
  Status flush(int32_t mip, Level& level);

  RectI samples_;
  int64_t next_y_ = 0;
  std::vector<Level> levels_;
  std::vector<uint16_t> tile_;
  Sink sink_;
};

}  // namespace loam
