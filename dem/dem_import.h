// Turning a DEM raster into a Loam world: choosing the quantization (offset and meters per
// unit with headroom above and below the data), padding to whole tiles with a flat apron at
// the data's edge height (the mean of its border samples), filling NoData with the minimum,
// and reporting the error that quantization introduced.
#pragma once

#include <cmath>
#include <optional>
#include <span>
#include <string>

#include "dem/dem_raster.h"
#include "protocol/world.h"

namespace loam {

struct ImportOptions {
  // Fraction of the data's height range kept free below its minimum and above its maximum,
  // so digging and building do not saturate at once. 0.25 = a quarter of the range each side.
  double headroom = 0.25;
  int32_t detail_factor = 4;
  double detail_meters_per_unit = 0.0;  // 0: a quarter of the coarse meters_per_unit
  int32_t origin_tile_x = 0;
  int32_t origin_tile_y = 0;
  // Optional crop of the raster before import: x, y, width, height in source samples.
  std::optional<RectI> crop;
};

struct ImportReport {
  std::string source;
  int64_t width = 0, height = 0;     // samples imported (after crop)
  int32_t tiles_x = 0, tiles_y = 0;  // world extent in whole tiles
  bool padded = false;               // the data does not fill the tiles: a flat apron pads it
  double apron_m = 0;                // the apron's height: the mean of the data's border samples
  double min_m = 0, max_m = 0;       // valid data range
  int64_t nodata_count = 0;
  double nodata_fill_m = 0;  // NoData samples are filled with the data minimum
  double meters_per_sample = 0, meters_per_unit = 0, height_offset = 0;
  double headroom_below_m = 0, headroom_above_m = 0;
  double max_error_m = 0, rms_error_m = 0;  // quantization error over valid samples
  bool exact = false;                       // every valid sample is represented exactly
  std::string scale_source;
  std::string scale_note;  // how georeferencing gave the spacing, when it did
  double anisotropy = 1.0;
  std::string orientation = "north-up";  // DemInfo::orientation: how the source was turned north-up

  std::string summary() const;  // multi-line human text
};

struct ImportedWorld {
  World world;
  ImportReport report;
};

Result<ImportedWorld> import_dem(const DemRaster& dem, const ImportOptions& options = {});

// --- The steps of an import, shared with the streamed import into a tile pack ---

// What an import learns of the samples before quantizing them, row by row (in any order).
struct DemStats {
  double lo = INFINITY, hi = -INFINITY;  // valid data range
  int64_t nodata = 0;
  double edge_sum = 0;  // valid samples on the imported area's border
  int64_t edge_count = 0;
  // Adds one row of the imported area (metres, NaN = no data); `border`: its first or last row.
  void add_row(std::span<const double> row, bool border);
};

// The quantization and extent of the world for `stats` over `crop` of `dem`: errors name the
// source (no valid sample, heights beyond +-1000 km, derived parameters invalid).
Result<WorldParams> import_params(const DemInfo& dem, const DemStats& stats, const RectI& crop,
                                  const ImportOptions& options);

// Quantizes rows into world samples and accumulates the error it introduced.
struct RowQuantizer {
  WorldParams params;
  uint16_t fill_q = 0;   // NoData: the data minimum
  uint16_t apron_q = 0;  // padding: the mean border height
  double max_err = 0, sum_sq = 0;
  int64_t valid = 0;
  RowQuantizer(const WorldParams& p, const DemStats& stats);
  // Row `data` (the imported area's width, or empty for a row below it) into `out`, one
  // world row (params.tiles_x tiles wide).
  void quantize(std::span<const double> data, std::span<uint16_t> out);
};

// The report of an import with these parameters, statistics and quantizer.
ImportReport import_report(const DemInfo& dem, const DemStats& stats, const RectI& crop,
                           const RowQuantizer& q);

}  // namespace loam
