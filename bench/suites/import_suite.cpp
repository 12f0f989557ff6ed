// Suite `import`: DEM import time and the quantization error it costs, for every DEM in
// data/ and ../shared/data/ (skipped, visibly, when that folder is absent).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/harness.h"
#include "dem/dem_import.h"
#include "dem/dem_raster.h"

namespace loam::bench {
namespace {

std::vector<std::string> dem_files(const std::string& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return out;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    const std::string ext = e.path().extension().string();
    if (ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".exr") out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

int run_import(const Context& ctx, Report& report) {
  std::vector<std::string> files = dem_files(ctx.source_dir + "/data");
  const std::vector<std::string> shared = dem_files(ctx.shared_data_dir);
  if (shared.empty()) {
    std::printf("import: SKIPPING shared DEMs: %s is absent\n", ctx.shared_data_dir.c_str());
    report.paragraph("**Shared DEMs skipped**: `" + ctx.shared_data_dir + "` is absent.");
  }
  files.insert(files.end(), shared.begin(), shared.end());
  if (ctx.quick && files.size() > 3) files.resize(3);

  Table table("import", {"dem", "samples", "read ms (median)", "quantize+tile ms (median)", "spread (total)",
                         "Msamples/s", "m/unit", "max error m", "rms error m", "exact"});
  Series read_series{"read (decode)", {}}, import_series{"quantize + tile", {}};
  int failures = 0;
  for (const std::string& path : files) {
    auto dem = read_dem_file(path);
    if (!dem) {
      std::fprintf(stderr, "import: %s\n", dem.error().describe().c_str());
      ++failures;
      continue;
    }
    auto imported = import_dem(*dem);
    if (!imported) {
      std::fprintf(stderr, "import: %s\n", imported.error().describe().c_str());
      ++failures;
      continue;
    }
    const Timing tr = measure(ctx, [&] { (void)read_dem_file(path); }, {.min_runs = 3, .min_seconds = 0.3});
    const Timing ti = measure(ctx, [&] { (void)import_dem(*dem); }, {.min_runs = 3, .min_seconds = 0.3});
    const Timing tt =
        measure(ctx, [&] { (void)import_dem(*read_dem_file(path)); }, {.min_runs = 3, .min_seconds = 0.3});
    const ImportReport& r = imported->report;
    const double samples = double(r.width * r.height);
    char buf[10][64];
    std::snprintf(buf[0], 64, "%lldx%lld", (long long)r.width, (long long)r.height);
    std::snprintf(buf[1], 64, "%.2f", tr.median_s * 1e3);
    std::snprintf(buf[2], 64, "%.2f", ti.median_s * 1e3);
    std::snprintf(buf[3], 64, "%s", tt.spread().c_str());
    std::snprintf(buf[4], 64, "%.1f", samples / tt.median_s / 1e6);
    std::snprintf(buf[5], 64, "%.4g", r.meters_per_unit);
    std::snprintf(buf[6], 64, "%.3g", r.max_error_m);
    std::snprintf(buf[7], 64, "%.3g", r.rms_error_m);
    const std::string name = std::filesystem::path(path).stem().string();
    table.add_row(
        {name, buf[0], buf[1], buf[2], buf[3], buf[4], buf[5], buf[6], buf[7], r.exact ? "yes" : "no"});
    read_series.points.push_back({samples / 1e6, tr.median_s * 1e3});
    import_series.points.push_back({samples / 1e6, ti.median_s * 1e3});
    std::printf("  %-28s %s read %.2f ms, import %.2f ms, max error %.3g m\n", name.c_str(), buf[0],
                tr.median_s * 1e3, ti.median_s * 1e3, r.max_error_m);
  }
  report.paragraph(
      "Each DEM is decoded (OpenImageIO), then quantized into 16-bit tiles with 25% headroom each side "
      "and NoData filled. Error is |dequantized - source| over valid samples; integer sources with a "
      "power-of-two step ratio import exactly. Times are medians of repeated runs (spread p10..p90).");
  report.table(std::move(table));
  std::sort(read_series.points.begin(), read_series.points.end());
  std::sort(import_series.points.begin(), import_series.points.end());
  report.plot({"import_time.png",
               "DEM import time against size",
               "megasamples",
               "milliseconds",
               true,
               true,
               {read_series, import_series},
               {}});
  return failures;
}

}  // namespace

LOAM_BENCH_SUITE(import, "DEM import time and quantization error for every DEM in data/ and shared/data/",
                 run_import);

}  // namespace loam::bench
