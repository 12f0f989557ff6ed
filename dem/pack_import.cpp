#include "dem/pack_import.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <vector>

#include "protocol/base/tile_row_pyramid.h"

namespace loam {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

Result<PackImportReport> import_dem_to_pack(const std::string& dem_path, const std::string& pack_path,
                                            const DemScaleOptions& scale, const ImportOptions& options,
                                            RegionEncoding encoding) {
  std::error_code ec;
  if (std::filesystem::exists(pack_path, ec))
    return make_error(ErrorCode::kInvalidArgument, pack_path, "already exists (a pack is never overwritten)");
  auto opened = open_dem_strips(dem_path, scale);
  if (!opened) return opened.error();
  DemStrips& dem = *opened;
  const DemInfo& info = dem.info();
  RectI crop{0, 0, info.width, info.height};
  if (options.crop) {
    crop = *options.crop;
    if (crop.empty() || !RectI{0, 0, info.width, info.height}.contains(crop))
      return make_error(ErrorCode::kInvalidArgument, info.name, "crop lies outside the image");
    if (crop.width() < 2 || crop.height() < 2)
      return make_error(ErrorCode::kInvalidArgument, info.name, "crop must be at least 2x2");
  }

  // Strips of source rows over the crop's rows, each handed to `row(y, samples)` in order.
  const int64_t strip = dem.strip_rows();
  std::vector<double> buf;
  auto for_each_row = [&](auto&& row) -> Status {
    for (int64_t y = crop.y0; y < crop.y1; y += strip) {
      const int64_t rows = std::min(strip, crop.y1 - y);
      buf.resize(size_t(rows * info.width));
      auto read = dem.read_rows(y, rows, buf);
      if (!read) return read.error();
      for (int64_t r = 0; r < rows; ++r) {
        LOAM_TRY(row(y + r, std::span<const double>(buf.data() + size_t(r * info.width + crop.x0),
                                                    size_t(crop.width()))));
      }
    }
    return {};
  };

  PackImportReport report;
  const auto t0 = std::chrono::steady_clock::now();
  DemStats stats;
  LOAM_TRY(for_each_row([&](int64_t y, std::span<const double> row) -> Status {
    stats.add_row(row, y == crop.y0 || y + 1 == crop.y1);
    return {};
  }));
  if (stats.nodata == crop.area())
    return make_error(ErrorCode::kInvalidArgument, info.name, "every sample is NaN or NoData");
  auto params = import_params(info, stats, crop, options);
  if (!params) return params.error();
  report.scan_seconds = seconds_since(t0);

  const auto t1 = std::chrono::steady_clock::now();
  auto writer = TilePackWriter::create(pack_path, *params, encoding);
  if (!writer) return writer.error();
  TileRowPyramid pyramid(*params, [&](int32_t mip, int32_t tx, int32_t ty, std::span<const uint16_t> s) {
    return writer->add(mip, tx, ty, s);
  });
  report.pyramid_bytes = pyramid.buffer_bytes();
  ImportRows rows(*params, stats, options.nodata_fill, crop.width(),
                  [&](std::span<const uint16_t> r) { return pyramid.add_row(r); });
  LOAM_TRY(for_each_row([&](int64_t, std::span<const double> row) { return rows.add(row); }));
  LOAM_TRY(rows.finish(params->sample_rect().height()));
  if (!pyramid.done()) return make_error(ErrorCode::kCorrupt, info.name, "the tile rows did not complete");
  auto summary = writer->finish();
  if (!summary) return summary.error();
  report.write_seconds = seconds_since(t1);
  report.pack = *summary;
  report.import = import_report(info, stats, crop, rows, options.nodata_fill);
  return report;
}

}  // namespace loam
