// Turning a DEM raster into a Loam world: choosing the quantization (offset and meters per
// unit with headroom above and below the data), padding to whole tiles with a flat apron at
// the data's edge height (the mean of its border samples), filling NoData (interpolated by
// default: dem/nodata_fill.h), and reporting the error that quantization introduced.
#pragma once

#include <cmath>
#include <functional>
#include <optional>
#include <span>
#include <string>

#include "dem/dem_raster.h"
#include "dem/nodata_fill.h"
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
  NodataFill nodata_fill;  // what missing samples become
};

struct ImportReport {
  std::string source;
  int64_t width = 0, height = 0;     // samples imported (after crop)
  int32_t tiles_x = 0, tiles_y = 0;  // world extent in whole tiles
  bool padded = false;               // the data does not fill the tiles: a flat apron pads it
  double apron_m = 0;                // the apron's height: the mean of the data's border samples
  double min_m = 0, max_m = 0;       // valid data range
  int64_t nodata_count = 0;
  NodataFill nodata_fill;
  int64_t nodata_interpolated = 0;  // interpolate: samples filled from data within reach
  double nodata_fill_m = 0;         // min / value, and interpolate's samples beyond reach
  double meters_per_sample = 0, meters_per_unit = 0, height_offset = 0;
  double headroom_below_m = 0, headroom_above_m = 0;
  double max_error_m = 0, rms_error_m = 0;  // quantization error over valid samples
  bool exact = false;                       // every valid sample is represented exactly
  std::string scale_source;
  std::string scale_note;  // how georeferencing gave the spacing, when it did
  double anisotropy = 1.0;
  std::string orientation = "north-up";  // DemInfo::orientation: how the source was turned north-up
  std::string distortion;                // DemInfo::distortion

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
// source (no valid sample, heights beyond +-1000 km, derived parameters invalid). A fill
// value:H outside the data's range widens the range quantized when there is NoData.
Result<WorldParams> import_params(const DemInfo& dem, const DemStats& stats, const RectI& crop,
                                  const ImportOptions& options);

// Quantizes rows into world samples and accumulates the error it introduced.
struct RowQuantizer {
  WorldParams params;
  uint16_t fill_q = 0;   // NoData left: the data minimum, or value:H
  uint16_t apron_q = 0;  // padding: the mean border height
  double max_err = 0, sum_sq = 0;
  int64_t valid = 0;
  RowQuantizer(const WorldParams& p, const DemStats& stats, const NodataFill& fill);
  // Row `data` (the imported area's width, or empty for a row below it) into `out`, one
  // world row (params.tiles_x tiles wide). The error is counted over the samples `source` (the
  // row before NoData was filled; empty: `data`) holds.
  void quantize(std::span<const double> data, std::span<uint16_t> out, std::span<const double> source = {});
};

// The rows of the imported area, in order, through the NoData fill into the quantizer and on
// to `out` (one world row each); then the apron rows below the data up to `world_rows`.
class ImportRows {
 public:
  using Out = std::function<Status(std::span<const uint16_t>)>;
  ImportRows(const WorldParams& p, const DemStats& stats, const NodataFill& fill, int64_t data_width,
             Out out);
  Status add(std::span<const double> data_row);
  Status finish(int64_t world_rows);  // after the last data row
  const RowQuantizer& quantizer() const { return q_; }
  int64_t interpolated() const { return filler_ ? filler_->filled() : 0; }

 private:
  Status quantize(std::span<const double> row, std::span<const double> source);
  RowQuantizer q_;
  Out out_;
  std::vector<uint16_t> world_row_;
  std::optional<NodataInterpolator> filler_;
  int64_t rows_out_ = 0;
};

// The report of an import with these parameters, statistics and rows.
ImportReport import_report(const DemInfo& dem, const DemStats& stats, const RectI& crop,
                           const ImportRows& rows, const NodataFill& fill);

}  // namespace loam
