// What an import puts where a DEM has no data (NaN or the band's NoData value). By default it
// interpolates: each missing sample looks along eight directions (the rows, the columns and
// the diagonals) for the nearest valid sample within kNodataSearchSamples and takes their
// inverse-square-distance weighted mean, as GDAL's GDALFillNodata does with its conic search.
// A hole thus meets its rim at the rim's heights instead of a floor with cliffs around it.
// Samples with no valid sample within that distance on any of the eight lines (the middle of
// a wide ocean) take the data minimum. `min` fills every missing sample with the minimum (what
// Loam did before: logs that name no fill replay so), `value:H` with H metres.
//
// The interpolation streams: rows go in in order and come out filled at most 1.5 search
// distances later, holding that many rows (96: 24 bytes a sample), so the tile-pack import of a
// raster of any height fills exactly as the import into memory does.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/result.h"

namespace loam {

inline constexpr int kNodataSearchSamples = 64;

struct NodataFill {
  enum class Mode : uint8_t { kInterpolate, kMin, kValue };
  Mode mode = Mode::kInterpolate;
  double value_m = 0;  // kValue

  // "interpolate", "min" or "value:H" (H in metres, |H| <= 1e6); errors say what is accepted.
  static Result<NodataFill> parse(std::string_view text);
  std::string to_string() const;  // parse(to_string()) gives it back
  friend bool operator==(const NodataFill&, const NodataFill&) = default;
};

// Fills the NaN samples of rows pushed in order (each `width` samples) by the interpolation
// above; `emit` receives each row, filled (a sample nothing reaches stays NaN), with the row as
// it was pushed, in the same order. Rows come out once the rows within the search distance below them are in,
// and the rest at finish(). An error returned by `emit` stops the filler and is returned.
class NodataInterpolator {
 public:
  using Emit = std::function<Status(std::span<const double> filled, std::span<const double> source)>;
  NodataInterpolator(int64_t width, Emit emit, int search = kNodataSearchSamples);

  Status push(std::span<const double> row);
  Status finish();

  int64_t filled() const { return filled_; }        // samples interpolated
  int64_t unreached() const { return unreached_; }  // NaN samples left (no valid sample in reach)
  size_t buffer_bytes() const;                      // what the rows in flight hold

 private:
  struct Row {
    std::vector<double> v;           // the source row, NaN = no data
    std::vector<double> sum_w, sum;  // weights and weighted heights found so far
  };
  // Nearest valid sample along a line so far: its height and distance in steps (0: none).
  struct Seen {
    double v = 0;
    int32_t steps = 0;
  };
  static Seen further(const Seen& s);  // one step further along its line
  void add(Row& r, size_t x, const Seen& s, double step_sq);
  // Moves a carry (the nearest valid sample along a line, per column) one row on, to `row`;
  // dx: the line's column step per row (0 straight, 1 and -1 the diagonals).
  void carry(std::vector<Seen>& c, const std::vector<double>& row, int dx);
  void look_up_and_sideways(Row& r);
  void look_down(size_t first_done);
  Status emit_front(size_t count);

  int64_t width_;
  int search_;
  Emit emit_;
  std::vector<Row> rows_;  // rows in flight, oldest first
  std::vector<Seen> above_, above_left_, above_right_;
  std::vector<Seen> below_, below_left_, below_right_, next_;
  std::vector<double> out_;
  int64_t filled_ = 0, unreached_ = 0;
};

// Fills `samples` (width x height, row-major) in place, as rows through a NodataInterpolator.
// Returns the samples interpolated.
int64_t interpolate_nodata(std::span<double> samples, int64_t width, int search = kNodataSearchSamples);

}  // namespace loam
