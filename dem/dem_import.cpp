#include "dem/dem_import.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace loam {

std::string ImportReport::summary() const {
  char apron_buf[64] = "";
  if (padded) std::snprintf(apron_buf, sizeof apron_buf, ", padded with a flat apron at %.3f m", apron_m);
  const std::string apron = apron_buf;
  char buf[1536];
  std::snprintf(buf, sizeof buf,
                "source            %s (scale from %s)\n"
                "samples           %lld x %lld -> %d x %d tiles of %d%s\n"
                "heights           %.3f .. %.3f m\n"
                "quantization      offset %.6f m, %.6g m/unit, %.6g m/sample%s\n"
                "headroom          %.1f m below, %.1f m above\n"
                "error             max %.6g m, rms %.6g m%s\n",
                source.c_str(), scale_source.c_str(), (long long)width, (long long)height, tiles_x, tiles_y,
                kTileSize, apron.c_str(), min_m, max_m, height_offset, meters_per_unit, meters_per_sample,
                anisotropy != 1.0 ? " (source samples not square)" : "", headroom_below_m, headroom_above_m,
                max_error_m, rms_error_m, exact ? " (exact)" : "");
  std::string out = buf;
  if (nodata_count > 0) {
    char nd[256];
    if (nodata_fill.mode == NodataFill::Mode::kInterpolate) {
      std::snprintf(
          nd, sizeof nd,
          "nodata            %lld samples: %lld interpolated, %lld beyond %d samples of data at %.3f m\n",
          (long long)nodata_count, (long long)nodata_interpolated,
          (long long)(nodata_count - nodata_interpolated), kNodataSearchSamples, nodata_fill_m);
    } else {
      std::snprintf(nd, sizeof nd, "nodata            %lld samples filled with %.3f m (%s)\n",
                    (long long)nodata_count, nodata_fill_m, nodata_fill.to_string().c_str());
    }
    out += nd;
  }
  if (!scale_note.empty()) out += "spacing           " + scale_note + "\n";
  if (orientation != "north-up") out += "orientation       " + orientation + "\n";
  if (!distortion.empty()) out += "distortion        " + distortion + "\n";
  return out;
}

void DemStats::add_row(std::span<const double> row, bool border) {
  for (const double v : row) {
    if (std::isnan(v)) {
      ++nodata;
      continue;
    }
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  // Padding to whole tiles is a flat apron at the data's edge height: the mean of the valid
  // samples on the imported area's border. (Repeating each edge sample instead drew streaks
  // across the world for a DEM smaller than a tile.)
  auto edge = [&](double v) {
    if (!std::isnan(v)) {
      edge_sum += v;
      ++edge_count;
    }
  };
  if (row.empty()) return;
  if (border) {
    for (const double v : row) edge(v);
  } else {
    edge(row.front());
    if (row.size() > 1) edge(row.back());
  }
}

Result<WorldParams> import_params(const DemInfo& dem, const DemStats& stats, const RectI& crop,
                                  const ImportOptions& options) {
  const std::string& name = dem.name;
  if (!std::isfinite(options.headroom) || options.headroom < 0 || options.headroom > 10) {
    return make_error(ErrorCode::kInvalidArgument, "headroom", "must be in 0..10");
  }
  if (!(stats.lo <= stats.hi))
    return make_error(ErrorCode::kInvalidArgument, name, "no valid sample in the imported area");
  const bool fill_value = stats.nodata > 0 && options.nodata_fill.mode == NodataFill::Mode::kValue;
  const double lo = fill_value ? std::min(stats.lo, options.nodata_fill.value_m) : stats.lo;
  const double hi = fill_value ? std::max(stats.hi, options.nodata_fill.value_m) : stats.hi;
  if (std::fabs(lo) > 1e6 || std::fabs(hi) > 1e6) {
    return make_error(ErrorCode::kInvalidArgument, name, "heights beyond +-1000 km are not terrain");
  }

  WorldParams p;
  p.meters_per_sample = dem.meters_per_sample;
  p.detail_factor = options.detail_factor;
  p.origin_tile_x = options.origin_tile_x;
  p.origin_tile_y = options.origin_tile_y;
  p.tiles_x = int32_t(ceil_div(crop.width(), kTileSize));
  p.tiles_y = int32_t(ceil_div(crop.height(), kTileSize));

  const double range = std::max(hi - lo, 1e-3);
  if (dem.loam_world && !options.crop && dem.loam_world->params.tiles_x == p.tiles_x &&
      dem.loam_world->params.tiles_y == p.tiles_y) {
    // A Loam export: keep its quantization so the round trip is exact.
    const WorldParams& w = dem.loam_world->params;
    p.height_offset = w.height_offset;
    p.meters_per_unit = w.meters_per_unit;
    p.detail_factor = w.detail_factor;
    p.detail_meters_per_unit = w.detail_meters_per_unit;
    p.meters_per_sample = w.meters_per_sample;
  } else if (dem.integer_source && dem.vertical_step > 0) {
    // Integer source: a power-of-two fraction (or multiple) of its step keeps every source
    // value exact whenever the range with headroom fits 16 bits.
    const double units = range / dem.vertical_step;
    const double needed = units * (1.0 + 2.0 * options.headroom);
    int k = 0;
    while (k < 16 && needed * std::ldexp(1.0, k + 1) <= 65535.0) ++k;
    while (k > -32 && needed * std::ldexp(1.0, k) > 65535.0) --k;
    p.meters_per_unit = std::ldexp(dem.vertical_step, -k);
    const double data_units = std::round(range / p.meters_per_unit);
    const double below = std::floor((65535.0 - data_units) / 2.0);
    p.height_offset = lo - below * p.meters_per_unit;
  } else {
    p.meters_per_unit = range * (1.0 + 2.0 * options.headroom) / 65535.0;
    p.height_offset = lo - options.headroom * range;
  }
  if (p.detail_meters_per_unit <= 0 || !dem.loam_world) {
    p.detail_meters_per_unit =
        options.detail_meters_per_unit > 0 ? options.detail_meters_per_unit : p.meters_per_unit / 4.0;
  }
  if (dem.loam_world && !options.crop)
    p.detail_meters_per_unit = dem.loam_world->params.detail_meters_per_unit;
  if (const Status st = p.validate(); !st.ok()) {
    return make_error(st.error().code, name, "derived world parameters invalid: " + st.error().describe());
  }
  return p;
}

RowQuantizer::RowQuantizer(const WorldParams& p, const DemStats& stats, const NodataFill& fill) : params(p) {
  const double apron_m =
      stats.edge_count ? std::clamp(stats.edge_sum / double(stats.edge_count), stats.lo, stats.hi) : stats.lo;
  fill_q = quantize_height(p, fill.mode == NodataFill::Mode::kValue ? fill.value_m : stats.lo);
  apron_q = quantize_height(p, apron_m);
}

void RowQuantizer::quantize(std::span<const double> data, std::span<uint16_t> out,
                            std::span<const double> source) {
  const size_t n = std::min(data.size(), out.size());
  if (source.size() != data.size()) source = data;
  for (size_t x = 0; x < n; ++x) {
    const double v = data[x];
    uint16_t q = fill_q;
    if (!std::isnan(v)) q = quantize_height(params, v);
    if (!std::isnan(source[x])) {
      const double err = std::fabs(params.height_meters(q) - v);
      max_err = std::max(max_err, err);
      sum_sq += err * err;
      ++valid;
    }
    out[x] = q;
  }
  std::fill(out.begin() + ptrdiff_t(n), out.end(), apron_q);
}

ImportRows::ImportRows(const WorldParams& p, const DemStats& stats, const NodataFill& fill,
                       int64_t data_width, Out out)
    : q_(p, stats, fill), out_(std::move(out)), world_row_(size_t(p.sample_rect().width())) {
  // Only a raster with NoData pays for the interpolation's rows in flight.
  if (stats.nodata > 0 && fill.mode == NodataFill::Mode::kInterpolate)
    filler_.emplace(data_width, [this](std::span<const double> row, std::span<const double> source) {
      return quantize(row, source);
    });
}

Status ImportRows::quantize(std::span<const double> row, std::span<const double> source) {
  q_.quantize(row, world_row_, source);
  ++rows_out_;
  return out_(world_row_);
}

Status ImportRows::add(std::span<const double> data_row) {
  return filler_ ? filler_->push(data_row) : quantize(data_row, data_row);
}

Status ImportRows::finish(int64_t world_rows) {
  if (filler_) LOAM_TRY(filler_->finish());
  while (rows_out_ < world_rows) LOAM_TRY(quantize({}, {}));  // below the data: the apron
  return {};
}

ImportReport import_report(const DemInfo& dem, const DemStats& stats, const RectI& crop,
                           const ImportRows& rows, const NodataFill& fill) {
  const RowQuantizer& q = rows.quantizer();
  const WorldParams& p = q.params;
  ImportReport r;
  r.source = dem.name;
  r.width = crop.width();
  r.height = crop.height();
  r.tiles_x = p.tiles_x;
  r.tiles_y = p.tiles_y;
  r.min_m = stats.lo;
  r.max_m = stats.hi;
  r.nodata_count = stats.nodata;
  r.nodata_fill = fill;
  r.nodata_interpolated = rows.interpolated();
  r.nodata_fill_m = p.height_meters(q.fill_q);
  r.apron_m = p.height_meters(q.apron_q);
  r.padded = int64_t(p.tiles_x) * kTileSize > crop.width() || int64_t(p.tiles_y) * kTileSize > crop.height();
  r.meters_per_sample = p.meters_per_sample;
  r.meters_per_unit = p.meters_per_unit;
  r.height_offset = p.height_offset;
  r.headroom_below_m = stats.lo - p.height_offset;
  r.headroom_above_m = p.height_meters(65535) - stats.hi;
  r.max_error_m = q.max_err;
  r.rms_error_m = q.valid ? std::sqrt(q.sum_sq / double(q.valid)) : 0.0;
  // Exact when every error is within double rounding of the heights themselves.
  r.exact = q.max_err <= 1e-9 * std::max(1.0, std::max(std::fabs(stats.lo), std::fabs(stats.hi)));
  r.scale_source = dem.scale_source;
  r.scale_note = dem.scale_note;
  r.anisotropy = dem.anisotropy;
  r.orientation = dem.orientation;
  r.distortion = dem.distortion;
  return r;
}

Result<ImportedWorld> import_dem(const DemRaster& dem, const ImportOptions& options) {
  const std::string& name = dem.name;
  RectI crop{0, 0, dem.width, dem.height};
  if (options.crop) {
    crop = *options.crop;
    if (crop.empty() || !RectI{0, 0, dem.width, dem.height}.contains(crop)) {
      return make_error(ErrorCode::kInvalidArgument, name, "crop lies outside the image");
    }
    if (crop.width() < 2 || crop.height() < 2) {
      return make_error(ErrorCode::kInvalidArgument, name, "crop must be at least 2x2");
    }
  }
  auto row = [&](int64_t y) {
    return std::span<const double>(dem.meters.data() + size_t(y * dem.width + crop.x0), size_t(crop.width()));
  };
  DemStats stats;
  for (int64_t y = crop.y0; y < crop.y1; ++y) stats.add_row(row(y), y == crop.y0 || y + 1 == crop.y1);
  auto params = import_params(dem, stats, crop, options);
  if (!params) return params.error();
  const WorldParams& p = *params;

  // Fill NoData, quantize, pad with the apron.
  const RectI world = p.sample_rect();
  const int64_t ww = world.width(), wh = world.height();
  std::vector<uint16_t> samples(size_t(ww * wh));
  size_t at = 0;
  ImportRows rows(p, stats, options.nodata_fill, crop.width(), [&](std::span<const uint16_t> r) {
    std::copy(r.begin(), r.end(), samples.begin() + ptrdiff_t(at));
    at += r.size();
    return Status{};
  });
  for (int64_t y = crop.y0; y < crop.y1; ++y) LOAM_TRY(rows.add(row(y)));
  LOAM_TRY(rows.finish(wh));
  auto built = World::from_samples(p, samples);
  if (!built) return built.error();
  return ImportedWorld{std::move(*built), import_report(dem, stats, crop, rows, options.nodata_fill)};
}

}  // namespace loam
