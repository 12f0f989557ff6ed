// Suite `import`: DEM import time, the spacing it derives, the quantization error it costs and
// the peak memory of a whole `loam-server import`, for every DEM in data/ and ../shared/data/
// (skipped, visibly, when that folder is absent) plus DEMs generated here in the formats the
// shared data lacks: SRTM HGT (SRTM3 and SRTM1), an ESRI ASCII grid, geographic and projected
// GeoTIFFs and a VRT window.
#include <fcntl.h>
#include <gdal.h>
#include <malloc.h>
#include <ogr_srs_api.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "bench/harness.h"
#include "dem/dem_import.h"
#include "dem/dem_raster.h"
#include "dem/gdal_errors.h"

namespace loam::bench {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> dem_files(const std::string& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return out;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string ext = e.path().extension().string();
    if (ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".exr" || ext == ".hgt" || ext == ".asc" ||
        ext == ".vrt")
      out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Rough terrain in metres: hills, ridges and noise, whole metres.
double terrain_at(int x, int y, double base, std::mt19937& rng) {
  std::uniform_real_distribution<double> noise(-4.0, 4.0);
  return std::round(base + 600.0 * std::sin(x * 0.004) * std::cos(y * 0.003) +
                    150.0 * std::sin(x * 0.03 + y * 0.02) + noise(rng));
}

bool write_hgt(const fs::path& path, int n) {
  std::mt19937 rng{uint32_t(n)};
  std::vector<uint8_t> bytes;
  bytes.reserve(size_t(n) * size_t(n) * 2);
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const auto v = uint16_t(int16_t(terrain_at(x, y, 1800.0, rng)));
      bytes.push_back(uint8_t(v >> 8));  // big-endian
      bytes.push_back(uint8_t(v));
    }
  }
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  return bool(out);
}

bool write_ascii_grid(const fs::path& path, int w, int h) {
  std::mt19937 rng(5);
  std::ofstream out(path);
  out << "ncols " << w << "\nnrows " << h << "\nxllcorner 400000\nyllcorner 4500000\ncellsize 30\n"
      << "NODATA_value -9999\n";
  char buf[32];
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      std::snprintf(buf, sizeof buf, "%.2f ", terrain_at(x, y, 300.0, rng) + 0.25 * ((x + y) % 4));
      out << buf;
    }
    out << '\n';
  }
  return bool(out);
}

// A GeoTIFF through GDAL: float32 heights, the given CRS and transform.
bool write_geotiff(const fs::path& path, int w, int h, int epsg, const std::array<double, 6>& transform) {
  ensure_gdal_ready();
  GdalErrorCapture quiet;
  GDALDriverH drv = GDALGetDriverByName("GTiff");
  const char* options[] = {"COMPRESS=DEFLATE", "TILED=YES", nullptr};
  GDALDatasetH ds =
      drv ? GDALCreate(drv, path.string().c_str(), w, h, 1, GDT_Float32, const_cast<char**>(options))
          : nullptr;
  if (!ds) return false;
  std::mt19937 rng{uint32_t(epsg)};
  std::vector<float> row(static_cast<size_t>(w));
  bool ok = true;
  GDALRasterBandH band = GDALGetRasterBand(ds, 1);
  for (int y = 0; y < h && ok; ++y) {
    for (int x = 0; x < w; ++x) row[size_t(x)] = float(terrain_at(x, y, 900.0, rng) + 0.125 * (x % 8));
    ok = GDALRasterIO(band, GF_Write, 0, y, w, 1, row.data(), w, 1, GDT_Float32, 0, 0) == CE_None;
  }
  GDALSetGeoTransform(ds, const_cast<double*>(transform.data()));
  OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
  if (OSRImportFromEPSG(srs, epsg) == OGRERR_NONE) GDALSetSpatialRef(ds, srs);
  OSRDestroySpatialReference(srs);
  GDALClose(ds);
  return ok;
}

// A projected float GeoTIFF with NoData (-9999): round holes of every size up to an "ocean"
// wider than the interpolation's reach, so the fill's cost and what it reaches are measured.
bool write_holed_geotiff(const fs::path& path, int w, int h) {
  if (!write_geotiff(path, w, h, 32632, {600000, 10, 0, 5200000, 0, -10})) return false;
  GdalErrorCapture quiet;
  GDALDatasetH ds = GDALOpen(path.string().c_str(), GA_Update);
  if (!ds) return false;
  GDALRasterBandH band = GDALGetRasterBand(ds, 1);
  GDALSetRasterNoDataValue(band, -9999.0);
  std::vector<float> row(static_cast<size_t>(w));
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0, 1);
  struct Hole {
    double x, y, r;
  };
  std::vector<Hole> holes{{0.8 * w, 0.75 * h, 0.2 * w}};  // the ocean: 2 x 205 samples across
  for (int i = 0; i < 60; ++i) holes.push_back({u(rng) * w, u(rng) * h, 2 + u(rng) * 30});
  bool ok = true;
  for (int y = 0; y < h && ok; ++y) {
    ok = GDALRasterIO(band, GF_Read, 0, y, w, 1, row.data(), w, 1, GDT_Float32, 0, 0) == CE_None;
    for (int x = 0; x < w; ++x) {
      for (const Hole& o : holes) {
        if ((x - o.x) * (x - o.x) + (y - o.y) * (y - o.y) <= o.r * o.r) row[size_t(x)] = -9999.0f;
      }
    }
    ok = ok && GDALRasterIO(band, GF_Write, 0, y, w, 1, row.data(), w, 1, GDT_Float32, 0, 0) == CE_None;
  }
  GDALClose(ds);
  return ok;
}

// DEMs in the formats shared/data lacks, written under `dir` (a temporary folder, kept between
// runs so repeated runs skip the writing).
std::vector<std::string> generated_dems(const Context& ctx, const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  std::vector<std::string> out;
  auto make = [&](const fs::path& p, auto&& writer) {
    if (!fs::exists(p) && !writer(p)) {
      std::fprintf(stderr, "import: cannot write %s\n", p.string().c_str());
      return;
    }
    out.push_back(p.string());
  };
  make(dir / "N47E011.hgt", [](const fs::path& p) { return write_hgt(p, 1201); });
  make(dir / "grid_utm30m_1000x800.asc", [](const fs::path& p) { return write_ascii_grid(p, 1000, 800); });
  const double d = 1.0 / 1200.0;  // 3 arc-seconds
  make(dir / "geographic_4326_1500x1200.tif", [&](const fs::path& p) {
    return write_geotiff(p, 1500, 1200, 4326, {10.5, d, 0, 47.9, 0, -d});
  });
  make(dir / "projected_utm32_1024x1024.tif", [](const fs::path& p) {
    return write_geotiff(p, 1024, 1024, 32632, {600000, 10, 0, 5200000, 0, -10});
  });
  make(dir / "window_of_geographic.vrt", [](const fs::path& p) {
    std::ofstream v(p);
    v << "<VRTDataset rasterXSize=\"700\" rasterYSize=\"500\">\n"
         "  <SRS>EPSG:4326</SRS>\n"
         "  <GeoTransform>10.6, 0.000833333333333, 0, 47.8, 0, -0.000833333333333</GeoTransform>\n"
         "  <VRTRasterBand dataType=\"Float32\" band=\"1\"><SimpleSource>\n"
         "    <SourceFilename relativeToVRT=\"1\">geographic_4326_1500x1200.tif</SourceFilename>\n"
         "    <SourceBand>1</SourceBand><SrcRect xOff=\"120\" yOff=\"120\" xSize=\"700\" ySize=\"500\"/>\n"
         "    <DstRect xOff=\"0\" yOff=\"0\" xSize=\"700\" ySize=\"500\"/>\n"
         "  </SimpleSource></VRTRasterBand>\n</VRTDataset>\n";
    return bool(v);
  });
  make(dir / "nodata_holes_utm32_1024x1024.tif",
       [](const fs::path& p) { return write_holed_geotiff(p, 1024, 1024); });
  if (!ctx.quick) make(dir / "N46E010.hgt", [](const fs::path& p) { return write_hgt(p, 3601); });
  return out;
}

// The most anonymous memory a forked child started with (MB).
double max_inherited_mb = 0;

// This process's anonymous resident memory (MB): what a forked child starts with.
double anon_rss_mb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("RssAnon:", 0) == 0) return std::stod(line.substr(8)) / 1024.0;
  }
  return 0;
}

// Peak RSS (MB) and exit code of `loam-server ARGS...` (e.g. `import FILE`) run as a child process. fork, not
// posix_spawn: a vfork'd child's peak would include this process's whole peak, while a forked
// one starts from this process's current anonymous pages only (returned to the system first
// with malloc_trim, and reported beside the numbers).
std::pair<double, int> server_peak_rss_mb(std::vector<std::string> args) {
  args.insert(args.begin(), LOAM_SERVER_BINARY);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  malloc_trim(0);
  max_inherited_mb = std::max(max_inherited_mb, anon_rss_mb());
  const pid_t pid = fork();
  if (pid == 0) {
    const int null = open("/dev/null", O_WRONLY);
    if (null >= 0) {
      dup2(null, 1);
      dup2(null, 2);
    }
    execv(argv[0], argv.data());
    _exit(127);
  }
  if (pid < 0) return {-1, -1};
  int status = 0;
  rusage usage{};
  if (wait4(pid, &status, 0, &usage) != pid) return {-1, -1};
  return {double(usage.ru_maxrss) / 1024.0, WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status)};
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
  const std::vector<std::string> generated =
      generated_dems(ctx, fs::temp_directory_path() / "loam-bench-import");
  files.insert(files.end(), generated.begin(), generated.end());

  Table table("import", {"dem", "format", "samples", "m/sample", "scale from", "read ms (median)",
                         "quantize+tile ms (median)", "spread (total)", "Msamples/s", "m/unit", "max error m",
                         "rms error m", "exact", "peak RSS MB (loam-server import)"});
  Series read_series{"read (decode)", {}}, import_series{"quantize + tile", {}};
  std::vector<std::string> notes;
  int failures = 0;
  // Every file as it comes, and the geographic GeoTIFF once more warped to square metres.
  struct Case {
    std::string path, label;
    DemScaleOptions scale;
    std::vector<std::string> args;
  };
  std::vector<Case> cases;
  for (const std::string& path : files) {
    const std::string name = fs::path(path).filename().string();
    cases.push_back({path, name, {}, {}});
    if (name.rfind("geographic_4326", 0) == 0) {
      DemScaleOptions aeqd;
      aeqd.project = LocalProjection::kAzimuthalEquidistant;
      cases.push_back({path, name + " (--project aeqd)", aeqd, {"--project", "aeqd"}});
    }
  }
  std::vector<std::string> nodata_notes, distortion_notes;
  for (const Case& c : cases) {
    const std::string& path = c.path;
    auto dem = read_dem_file(path, c.scale);
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
    // The quick run (CI's smoke run, under the sanitizers) times each step once: its numbers are
    // not reported anywhere, only that every step runs.
    const MeasureOptions opts =
        ctx.quick ? MeasureOptions{.warmup = 0, .min_runs = 1, .max_runs = 1, .min_seconds = 0}
                  : MeasureOptions{.min_runs = 3, .max_runs = 1000, .min_seconds = 0.3};
    const Timing tr = measure(
        ctx, [&] { (void)read_dem_file(path, c.scale); }, opts);
    const Timing ti = measure(
        ctx, [&] { (void)import_dem(*dem); }, opts);
    const Timing tt = measure(
        ctx, [&] { (void)import_dem(*read_dem_file(path, c.scale)); }, opts);
    std::vector<std::string> args{"import", path};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const auto [rss_mb, rc] = server_peak_rss_mb(args);
    if (rc != 0) {
      std::fprintf(stderr, "import: loam-server import %s exited %d\n", path.c_str(), rc);
      ++failures;
    }
    const ImportReport& r = imported->report;
    const double samples = double(r.width * r.height);
    char buf[11][64];
    std::snprintf(buf[0], 64, "%lldx%lld", (long long)r.width, (long long)r.height);
    std::snprintf(buf[1], 64, "%.2f", tr.median_s * 1e3);
    std::snprintf(buf[2], 64, "%.2f", ti.median_s * 1e3);
    std::snprintf(buf[3], 64, "%s", tt.spread().c_str());
    std::snprintf(buf[4], 64, "%.1f", samples / tt.median_s / 1e6);
    std::snprintf(buf[5], 64, "%.4g", r.meters_per_unit);
    std::snprintf(buf[6], 64, "%.3g", r.max_error_m);
    std::snprintf(buf[7], 64, "%.3g", r.rms_error_m);
    std::snprintf(buf[8], 64, "%.4g", r.meters_per_sample);
    std::snprintf(buf[9], 64, "%.1f", rss_mb);
    const std::string& name = c.label;
    table.add_row({name, dem->format, buf[0], buf[8], r.scale_source, buf[1], buf[2], buf[3], buf[4], buf[5],
                   buf[6], buf[7], r.exact ? "yes" : "no", buf[9]});
    if (!r.scale_note.empty()) notes.push_back("- `" + name + "`: " + r.scale_note);
    if (!r.distortion.empty()) distortion_notes.push_back("- `" + name + "`: " + r.distortion);
    if (r.nodata_count > 0) {
      char nd[256];
      std::snprintf(nd, sizeof nd,
                    "- `%s`: %lld NoData samples (%.1f%%), %lld interpolated, %lld beyond reach at %.3f m",
                    name.c_str(), (long long)r.nodata_count, 100.0 * double(r.nodata_count) / samples,
                    (long long)r.nodata_interpolated, (long long)(r.nodata_count - r.nodata_interpolated),
                    r.nodata_fill_m);
      nodata_notes.push_back(nd);
    }
    read_series.points.push_back({samples / 1e6, tr.median_s * 1e3});
    import_series.points.push_back({samples / 1e6, ti.median_s * 1e3});
    std::printf(
        "  %-34s %-8s %s %.4g m/sample (%s) read %.2f ms, import %.2f ms, max error %.3g m, %.1f MB\n",
        name.c_str(), dem->format.c_str(), buf[0], r.meters_per_sample, r.scale_source.c_str(),
        tr.median_s * 1e3, ti.median_s * 1e3, r.max_error_m, rss_mb);
  }
  report.paragraph(
      "Each DEM is read through GDAL (the OpenEXR library for OpenEXR) in strips of rows, then quantized "
      "into 16-bit "
      "tiles with 25% headroom each side, NoData filled and the last tiles padded with a flat apron. Error "
      "is "
      "|dequantized - source| over valid samples; integer sources with a power-of-two step ratio import "
      "exactly. Times are medians of repeated runs (spread p10..p90). Peak RSS is that of a whole "
      "`loam-server import FILE` child process (getrusage through wait4), the program and GDAL included. "
      "Rows after the shared DEMs are generated by the suite (in a temporary folder, loam-bench-import): "
      "SRTM HGT (3 and 1 arc-second), an ESRI ASCII grid (no .prj: its cell size is taken as metres), "
      "float GeoTIFFs in EPSG:4326 and UTM 32N (the geographic one also warped to square metres with "
      "`--project aeqd`), a VRT window of the geographic one, and a UTM GeoTIFF with NoData holes of every "
      "size up to an ocean wider than the interpolation's reach (NoData is interpolated by default: "
      "docs/world.md).");
  report.table(std::move(table));
  char floor[512];
  const auto [floor_mb, floor_rc] = server_peak_rss_mb({"--version"});
  std::snprintf(
      floor, sizeof floor,
      "Peak RSS floor: `loam-server --version` peaks at %.1f MB (the start-up of its shared libraries, "
      "GDAL's most of it); a DEM's import is what a row adds to that. Each child is forked and "
      "exec'd (this process held up to %.1f MB of anonymous memory at the forks; the small rows staying "
      "near the floor show none of it is counted), and the column agrees with `/usr/bin/time -v "
      "loam-server import FILE` to a few MB (time reads slightly higher).",
      floor_mb, max_inherited_mb);
  if (floor_rc == 0) report.paragraph(floor);
  if (!nodata_notes.empty()) {
    std::string text =
        "NoData filled (interpolated from the data within 64 samples along eight lines; beyond "
        "that the data minimum):\n\n";
    for (const auto& n : nodata_notes) text += n + "\n";
    report.paragraph(text);
  }
  if (!distortion_notes.empty()) {
    std::string text = "Distortion of geographic DEMs in Loam's square samples:\n\n";
    for (const auto& n : distortion_notes) text += n + "\n";
    report.paragraph(text);
  }
  if (!notes.empty()) {
    std::string text = "Spacing derived from the georeferencing:\n\n";
    for (const auto& n : notes) text += n + "\n";
    report.paragraph(text);
  }
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

LOAM_BENCH_SUITE(import,
                 "DEM import time, spacing, quantization error and peak memory for every DEM in data/, "
                 "shared/data/ and generated HGT, ASCII grid, GeoTIFF and VRT files",
                 run_import);

}  // namespace loam::bench
