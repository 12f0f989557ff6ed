#include <cpl_conv.h>
#include <gdal.h>
#include <gtest/gtest.h>
#include <ogr_srs_api.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <random>
#include <span>

#include "dem/default_terrain.h"
#include "dem/dem_export.h"
#include "dem/dem_import.h"
#include "dem/dem_raster.h"
#include "dem/gdal_errors.h"
#include "dem/image_file.h"

namespace loam {
namespace {

namespace fs = std::filesystem;

fs::path temp_dir() {
  const fs::path dir = fs::temp_directory_path() /
                       ("loam_dem_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
                        "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
  fs::create_directories(dir);
  return dir;
}

void write_bytes(const fs::path& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

std::vector<uint8_t> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

void write_float_image(const fs::path& path, int w, int h, const std::vector<float>& px) {
  const Status s = write_image_file(path.string(), image_view(w, h, 1, std::span<const float>(px)));
  ASSERT_TRUE(s.ok()) << s.error().describe();
}

// A raster written through GDAL (MEM, then CreateCopy to the driver), for tests of formats,
// CRSs and band properties.
struct TestBand {
  std::vector<double> values;
  GDALColorInterp color = GCI_GrayIndex;
  std::optional<double> nodata, scale, offset;
  std::string unit;
};

struct TestRaster {
  int width = 0, height = 0;
  GDALDataType type = GDT_Float32;
  std::vector<TestBand> bands;
  std::optional<std::array<double, 6>> transform;
  int epsg = 0;
  std::vector<std::string> creation_options;
};

void write_raster(const fs::path& path, const char* driver, const TestRaster& r) {
  ensure_gdal_ready();
  GdalErrorCapture quiet;
  GDALDriverH mem = GDALGetDriverByName("MEM");
  ASSERT_NE(mem, nullptr);
  GDALDatasetH ds = GDALCreate(mem, "", r.width, r.height, int(r.bands.size()), r.type, nullptr);
  ASSERT_NE(ds, nullptr);
  for (size_t i = 0; i < r.bands.size(); ++i) {
    const TestBand& b = r.bands[i];
    GDALRasterBandH band = GDALGetRasterBand(ds, int(i + 1));
    ASSERT_EQ(b.values.size(), size_t(r.width) * size_t(r.height));
    ASSERT_EQ(GDALRasterIO(band, GF_Write, 0, 0, r.width, r.height, const_cast<double*>(b.values.data()),
                           r.width, r.height, GDT_Float64, 0, 0),
              CE_None);
    GDALSetRasterColorInterpretation(band, b.color);
    if (b.nodata) GDALSetRasterNoDataValue(band, *b.nodata);
    if (b.scale) GDALSetRasterScale(band, *b.scale);
    if (b.offset) GDALSetRasterOffset(band, *b.offset);
    if (!b.unit.empty()) GDALSetRasterUnitType(band, b.unit.c_str());
  }
  if (r.transform) GDALSetGeoTransform(ds, const_cast<double*>(r.transform->data()));
  if (r.epsg) {
    OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
    ASSERT_EQ(OSRImportFromEPSG(srs, r.epsg), OGRERR_NONE) << "EPSG:" << r.epsg;
    GDALSetSpatialRef(ds, srs);
    OSRDestroySpatialReference(srs);
  }
  std::vector<const char*> options;
  for (const std::string& o : r.creation_options) options.push_back(o.c_str());
  options.push_back(nullptr);
  GDALDatasetH out = GDALCreateCopy(GDALGetDriverByName(driver), path.string().c_str(), ds, FALSE,
                                    const_cast<char**>(options.data()), nullptr, nullptr);
  ASSERT_NE(out, nullptr) << quiet.text("CreateCopy failed");
  GDALClose(out);
  GDALClose(ds);
}

// Rough terrain: hills plus deterministic noise, heights in metres.
std::vector<double> rough_terrain(int w, int h, uint32_t seed, double base = 500.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> noise(-3.0, 3.0);
  std::vector<double> v(size_t(w) * size_t(h));
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      v[size_t(y) * size_t(w) + size_t(x)] =
          std::round(base + 120.0 * std::sin(x * 0.07) * std::cos(y * 0.05) +
                     30.0 * std::sin(x * 0.31 + y * 0.17) + noise(rng));
    }
  }
  return v;
}

TestBand band_of(std::vector<double> values, GDALColorInterp color = GCI_GrayIndex) {
  TestBand b;
  b.values = std::move(values);
  b.color = color;
  return b;
}

TestRaster single_band(int w, int h, GDALDataType type, std::vector<double> values) {
  TestRaster r;
  r.width = w;
  r.height = h;
  r.type = type;
  r.bands.push_back(band_of(std::move(values)));
  return r;
}

// The metres per sample of a geographic grid at latitude `lat` on WGS 84 (x: along a row).
std::pair<double, double> wgs84_spacing(double lat_deg, double dlon_deg, double dlat_deg) {
  const double a = 6378137.0, f = 1.0 / 298.257223563, e2 = f * (2 - f);
  const double phi = lat_deg * M_PI / 180.0;
  const double w = 1 - e2 * std::sin(phi) * std::sin(phi);
  const double n = a / std::sqrt(w), m = a * (1 - e2) / std::pow(w, 1.5);
  return {n * std::cos(phi) * dlon_deg * M_PI / 180.0, m * dlat_deg * M_PI / 180.0};
}

uint32_t crc32(const uint8_t* p, size_t n) {
  uint32_t c = 0xffffffffu;
  for (size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return c ^ 0xffffffffu;
}

void put_be32(std::vector<uint8_t>& b, uint32_t v) {
  for (int i = 3; i >= 0; --i) b.push_back(uint8_t(v >> (8 * i)));
}

void png_chunk(std::vector<uint8_t>& b, const char* type, const std::vector<uint8_t>& data) {
  put_be32(b, uint32_t(data.size()));
  const size_t start = b.size();
  b.insert(b.end(), type, type + 4);
  b.insert(b.end(), data.begin(), data.end());
  put_be32(b, crc32(b.data() + start, b.size() - start));
}

// A ~1 KB 16-bit grayscale PNG whose header claims w x h (valid signature and CRCs) and
// whose pixel data is a few hundred bytes of a deflate stream that ends early.
std::vector<uint8_t> png_claiming(uint32_t w, uint32_t h, uint8_t color_type = 0) {
  std::vector<uint8_t> b = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<uint8_t> ihdr;
  put_be32(ihdr, w);
  put_be32(ihdr, h);
  ihdr.insert(ihdr.end(), {16, color_type, 0, 0, 0});
  png_chunk(b, "IHDR", ihdr);
  std::vector<uint8_t> idat = {0x78, 0x01, 0x00, 0xff, 0x03, 0x00, 0xfc};  // a stored block of 1023 bytes...
  for (int i = 0; i < 900; ++i) idat.push_back(uint8_t(i * 7));            // ...with only 900 present
  png_chunk(b, "IDAT", idat);
  png_chunk(b, "IEND", {});
  return b;
}

// A little-endian uint16 TIFF whose header claims w x h in one uncompressed strip, followed
// by only `present` bytes of that strip.
std::vector<uint8_t> tiff_claiming(uint32_t w, uint32_t h, uint32_t present) {
  std::vector<uint8_t> b;
  auto u16 = [&](uint16_t v) {
    b.push_back(uint8_t(v));
    b.push_back(uint8_t(v >> 8));
  };
  auto u32 = [&](uint32_t v) {
    for (int i = 0; i < 4; ++i) b.push_back(uint8_t(v >> (8 * i)));
  };
  const uint16_t ntags = 9;
  const uint32_t data_at = 8 + 2 + ntags * 12 + 4;
  const uint64_t claimed = uint64_t(w) * h * 2;
  b.insert(b.end(), {'I', 'I'});
  u16(42);
  u32(8);
  u16(ntags);
  auto tag = [&](uint16_t t, uint16_t type, uint32_t value) {
    u16(t);
    u16(type);
    u32(1);
    u32(value);
  };
  tag(256, 4, w);
  tag(257, 4, h);
  tag(258, 3, 16);
  tag(259, 3, 1);
  tag(262, 3, 1);
  tag(273, 4, data_at);
  tag(277, 3, 1);
  tag(278, 4, h);
  tag(279, 4, uint32_t(std::min<uint64_t>(claimed, 0xffffffffu)));
  u32(0);
  for (uint32_t i = 0; i < present; ++i) b.push_back(uint8_t(i * 13));
  return b;
}

long peak_rss_kb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

// How many MiB a forked child's peak RSS grows while it runs `fn` (forked, so that earlier
// tests' peaks in this process do not hide it); nullopt when `fn` fails.
std::optional<int> child_peak_growth_mb(const std::function<bool()>& fn) {
  const pid_t pid = fork();
  if (pid == 0) {
    const long before = peak_rss_kb();
    const bool ok = fn();
    _exit(ok ? int(std::clamp((peak_rss_kb() - before) / 1024, 0L, 254L)) : 255);
  }
  int status = 0;
  if (pid < 0 || waitpid(pid, &status, 0) != pid || !WIFEXITED(status) || WEXITSTATUS(status) == 255) {
    return std::nullopt;
  }
  return WEXITSTATUS(status);
}

std::string expect_refused(const fs::path& path, const DemScaleOptions& options = {}) {
  auto r = read_dem_file(path.string(), options);
  EXPECT_FALSE(r.ok()) << path.filename() << " was read";
  return r.ok() ? std::string() : r.error().describe();
}

std::vector<fs::path> dems_in(const fs::path& dir) {
  std::vector<fs::path> out;
  if (!fs::is_directory(dir)) return out;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".png") out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The embedded default terrain, read through GDAL from memory, is the world the golden replay
// logs start from (tests/golden/replay/*.loamlog record this initial world hash).
TEST(DefaultTerrain, WorldHashIsTheOneTheGoldenReplayLogsStartFrom) {
  auto w = load_default_terrain();
  ASSERT_TRUE(w.ok()) << w.error().describe();
  // The committed replay logs (format 1) recorded the legacy content hash (every tile); the
  // world hash adds the parameters; the current hashes cover the base and the edited tiles.
  EXPECT_EQ(w->world.legacy_content_hash(), 0xba2054acb5359522ull);
  EXPECT_EQ(w->world.legacy_world_hash(), 0x1174153942df9446ull);
  EXPECT_EQ(w->world.content_hash(), 0xf496d4c8105e0c43ull);
  EXPECT_EQ(w->world.world_hash(), 0x0363dc25e28241acull);
  EXPECT_FALSE(w->report.padded);
}

TEST(DefaultTerrain, LoadsExactlyWithHeadroomOnBothSides) {
  auto w = load_default_terrain();
  ASSERT_TRUE(w.ok()) << w.error().describe();
  const ImportReport& r = w->report;
  EXPECT_EQ(r.width, 1024);
  EXPECT_EQ(r.height, 768);
  EXPECT_EQ(r.tiles_x, 4);
  EXPECT_EQ(r.tiles_y, 3);
  EXPECT_TRUE(r.exact) << "an integer DEM with a power-of-two step ratio must import exactly";
  const double range = r.max_m - r.min_m;
  EXPECT_GE(r.headroom_below_m, 0.25 * range);
  EXPECT_GE(r.headroom_above_m, 0.25 * range);
  EXPECT_EQ(r.scale_source, "sidecar");
}

// Round trip of every DEM through float EXR export: the re-read heights differ from the
// source by at most the reported quantization error plus float32 rounding.
void expect_exr_round_trip(const fs::path& png, const fs::path& dir) {
  auto dem = read_dem_file(png.string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  auto imported = import_dem(*dem);
  ASSERT_TRUE(imported.ok()) << imported.error().describe();
  const World& w = imported->world;
  const fs::path exr = dir / (png.stem().string() + ".exr");
  ASSERT_TRUE(export_exr(w, w.params().sample_rect(), exr.string()).ok());
  DemScaleOptions keep;
  keep.meters_per_sample = dem->meters_per_sample;
  auto back = read_dem_file(exr.string(), keep);
  ASSERT_TRUE(back.ok()) << back.error().describe();
  double worst = 0;
  for (int64_t y = 0; y < dem->height; ++y) {
    for (int64_t x = 0; x < dem->width; ++x) {
      const double src = dem->meters[size_t(y * dem->width + x)];
      if (std::isnan(src)) continue;
      const double got = back->meters[size_t(y * back->width + x)];
      const double tol = imported->report.max_error_m + std::fabs(src) * 1.2e-7 + 1e-9;
      const double err = std::fabs(got - src);
      worst = std::max(worst, err);
      ASSERT_LE(err, tol) << png.filename() << " sample " << x << "," << y;
    }
  }
  // And through 16-bit PNG + sidecar: the world comes back bit for bit.
  const fs::path out_png = dir / (png.stem().string() + "_export.png");
  ASSERT_TRUE(export_png16(w, w.params().sample_rect(), out_png.string()).ok());
  auto again = read_dem_file(out_png.string());
  ASSERT_TRUE(again.ok()) << again.error().describe();
  auto reimported = import_dem(*again);
  ASSERT_TRUE(reimported.ok());
  EXPECT_EQ(reimported->world.params(), w.params());
  EXPECT_EQ(reimported->world.world_hash(), w.world_hash()) << png.filename();
}

TEST(DemImport, EveryShippedDemRoundTripsWithinReportedError) {
  const auto files = dems_in(fs::path(LOAM_SOURCE_DIR) / "data");
  ASSERT_FALSE(files.empty());
  const fs::path dir = temp_dir();
  for (const auto& f : files) expect_exr_round_trip(f, dir);
  fs::remove_all(dir);
}

TEST(DemImport, EverySharedDemRoundTripsWithinReportedError) {
  const auto files = dems_in(LOAM_SHARED_DATA_DIR);
  if (files.empty()) GTEST_SKIP() << "shared DEMs absent: " << LOAM_SHARED_DATA_DIR;
  const fs::path dir = temp_dir();
  for (const auto& f : files) expect_exr_round_trip(f, dir);
  fs::remove_all(dir);
}

// The reports built on the shared DEMs (lod, codec, import) import them as before the NoData fill
// became a choice: none of them holds NoData (their sidecars state the spacing, so no
// projection applies either), so the default fill and the old minimum fill give the same world.
TEST(DemImport, EverySharedDemImportsAsBeforeTheFillWasAChoice) {
  const auto files = dems_in(LOAM_SHARED_DATA_DIR);
  if (files.empty()) GTEST_SKIP() << "shared DEMs absent: " << LOAM_SHARED_DATA_DIR;
  for (const auto& f : files) {
    auto dem = read_dem_file(f.string());
    ASSERT_TRUE(dem.ok()) << dem.error().describe();
    EXPECT_EQ(dem->nodata_count, 0) << f;
    EXPECT_EQ(dem->scale_source, "sidecar") << f;
    ImportOptions min;
    min.nodata_fill.mode = NodataFill::Mode::kMin;
    auto a = import_dem(*dem), b = import_dem(*dem, min);
    ASSERT_TRUE(a.ok() && b.ok()) << f;
    EXPECT_EQ(a->world.world_hash(), b->world.world_hash()) << f;
  }
}

TEST(DemImport, FloatSourceErrorIsAtMostHalfAUnit) {
  const fs::path dir = temp_dir();
  std::vector<float> px(300 * 200);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> dist(-50.0f, 2500.0f);
  for (auto& v : px) v = dist(rng);
  write_float_image(dir / "f.exr", 300, 200, px);
  auto dem = read_dem_file((dir / "f.exr").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  auto w = import_dem(*dem);
  ASSERT_TRUE(w.ok());
  EXPECT_EQ(w->report.tiles_x, 2);
  EXPECT_EQ(w->report.tiles_y, 1);
  EXPECT_LE(w->report.max_error_m, w->report.meters_per_unit * 0.5 * (1 + 1e-9));
  EXPECT_GT(w->report.max_error_m, 0.0);
  // Padding is the flat apron, not a repeat of the edge samples.
  EXPECT_TRUE(w->report.padded);
  EXPECT_EQ(w->world.coarse(400, 10), quantize_height(w->world.params(), w->report.apron_m));
  EXPECT_EQ(w->world.coarse(400, 10), w->world.coarse(511, 255));
  fs::remove_all(dir);
}

TEST(DemImport, TiffNoDataFilledWithTheMinimumOrAValueWhenAsked) {
  const fs::path dir = temp_dir();
  std::vector<double> px(16 * 8, 100.0);
  px[5] = -9999.0;
  px[17] = -9999.0;
  px[40] = 20.0;
  TestRaster r = single_band(16, 8, GDT_Float32, px);
  r.bands[0].nodata = -9999.0;
  r.transform = std::array<double, 6>{500000, 30, 0, 5000000, 0, -30};
  r.epsg = 32633;  // WGS 84 / UTM zone 33N
  write_raster(dir / "nd.tif", "GTiff", r);
  auto dem = read_dem_file((dir / "nd.tif").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  EXPECT_EQ(dem->nodata_count, 2);
  EXPECT_EQ(dem->scale_source, "georeferencing");
  EXPECT_DOUBLE_EQ(dem->meters_per_sample, 30.0);
  ImportOptions min;
  min.nodata_fill = *NodataFill::parse("min");
  auto w = import_dem(*dem, min);
  ASSERT_TRUE(w.ok());
  EXPECT_EQ(w->report.nodata_count, 2);
  EXPECT_EQ(w->report.nodata_interpolated, 0);
  EXPECT_NEAR(w->report.nodata_fill_m, 20.0, w->report.meters_per_unit);
  EXPECT_EQ(w->world.coarse(5, 0), w->world.coarse(8, 2)) << "NoData sample gets the fill (the minimum)";
  EXPECT_NE(w->report.summary().find("2 samples filled with 19.999 m (min)"), std::string::npos)
      << w->report.summary();  // the minimum as quantized
  // A value beyond the data's range widens the range quantized.
  ImportOptions value;
  value.nodata_fill = *NodataFill::parse("value:-50");
  auto v = import_dem(*dem, value);
  ASSERT_TRUE(v.ok());
  EXPECT_NEAR(v->world.params().height_meters(v->world.coarse(5, 0)), -50.0, v->report.meters_per_unit);
  EXPECT_NEAR(v->world.params().height_meters(v->world.coarse(2, 2)), 100.0, v->report.meters_per_unit);
  EXPECT_LT(v->world.params().height_offset, -50.0);
  // By default they are interpolated from the samples around them (all 100 m here).
  auto i = import_dem(*dem);
  ASSERT_TRUE(i.ok());
  EXPECT_EQ(i->report.nodata_interpolated, 2);
  EXPECT_NEAR(i->world.params().height_meters(i->world.coarse(5, 0)), 100.0, i->report.meters_per_unit);
  fs::remove_all(dir);
}

// The case that filed the issue: a 95 x 90 Int16 GeoTIFF with 3,942 NoData samples came in as a
// flat floor at its minimum with cliffs around it. Interpolated, the hole meets its rim.
TEST(DemImport, AGeoTiffsNoDataHoleIsInterpolatedFromItsRimWithoutCliffs) {
  const fs::path dir = temp_dir();
  const int w = 95, h = 90;
  std::vector<double> v = rough_terrain(w, h, 31);
  int64_t hole = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if ((x - 50) * (x - 50) + (y - 40) * (y - 40) <= 35 * 35) {
        v[size_t(y * w + x)] = -32768;
        ++hole;
      }
    }
  }
  ASSERT_EQ(hole, 3853);
  TestRaster r = single_band(w, h, GDT_Int16, v);
  r.bands[0].nodata = -32768;
  r.transform = std::array<double, 6>{500000, 30, 0, 5000000, 0, -30};
  r.epsg = 32633;
  write_raster(dir / "hole.tif", "GTiff", r);
  auto dem = read_dem_file((dir / "hole.tif").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  auto imported = import_dem(*dem);
  ASSERT_TRUE(imported.ok()) << imported.error().describe();
  const ImportReport& rep = imported->report;
  EXPECT_EQ(rep.nodata_count, hole);
  EXPECT_EQ(rep.nodata_interpolated, hole);
  EXPECT_NE(rep.summary().find("3853 interpolated"), std::string::npos) << rep.summary();
  const World& world = imported->world;
  // The steepest step between neighbours inside the hole is no steeper than the data's own.
  auto m = [&](int x, int y) { return world.params().height_meters(world.coarse(x, y)); };
  auto in_hole = [&](int x, int y) { return (x - 50) * (x - 50) + (y - 40) * (y - 40) <= 35 * 35; };
  double data_step = 0, hole_step = 0;
  int64_t at_min = 0;
  for (int y = 1; y < h; ++y) {
    for (int x = 1; x < w; ++x) {
      const double step = std::max(std::fabs(m(x, y) - m(x - 1, y)), std::fabs(m(x, y) - m(x, y - 1)));
      const bool hole_edge = in_hole(x, y) || in_hole(x - 1, y) || in_hole(x, y - 1);
      (hole_edge ? hole_step : data_step) = std::max(hole_edge ? hole_step : data_step, step);
      at_min += in_hole(x, y) && std::fabs(m(x, y) - rep.min_m) < 1e-9;
    }
  }
  EXPECT_LE(hole_step, data_step);
  EXPECT_LT(at_min, hole / 100) << "no floor at the minimum";
  // `min` gives the floor with its cliffs back, as before.
  ImportOptions min;
  min.nodata_fill.mode = NodataFill::Mode::kMin;
  auto floor = import_dem(*dem, min);
  ASSERT_TRUE(floor.ok());
  EXPECT_EQ(floor->world.coarse(50, 40), quantize_height(floor->world.params(), rep.min_m));
  fs::remove_all(dir);
}

// The bug: a geographic GeoTIFF's pixel size in degrees was taken as metres (0.083 m).
TEST(DemImport, GeographicGeoTiffGetsMetresAtCentreLatitude) {
  const fs::path dir = temp_dir();
  const double d = 3.0 / 3600.0;  // 3 arc-seconds
  TestRaster r = single_band(91, 67, GDT_Int16, rough_terrain(91, 67, 11));
  // Centre latitude: 47.6 - 33.5 * d.
  r.transform = std::array<double, 6>{11.2, d, 0, 47.6, 0, -d};
  r.epsg = 4326;
  write_raster(dir / "geo.tif", "GTiff", r);
  auto dem = read_dem_file((dir / "geo.tif").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  const auto [x, y] = wgs84_spacing(47.6 - 33.5 * d, d, d);
  EXPECT_NEAR(x, 62.7, 0.3);
  EXPECT_NEAR(y, 92.6, 0.3);
  EXPECT_EQ(dem->scale_source, "georeferencing");
  EXPECT_NEAR(dem->meters_per_sample, std::sqrt(x * y), 1e-9 * std::sqrt(x * y));
  EXPECT_NEAR(dem->anisotropy, y / x, 1e-12);
  EXPECT_NE(dem->scale_note.find("WGS 84"), std::string::npos) << dem->scale_note;
  EXPECT_NE(dem->scale_note.find("centre latitude 47.5721"), std::string::npos) << dem->scale_note;
  fs::remove_all(dir);
}

// The spacing a geographic grid gets is the one shared/data's ETOPO5 sidecar states. The
// sidecar used the usual series for metres per degree of WGS 84 (110574.275 m per degree of
// latitude at the equator); Loam evaluates the ellipsoid's radii directly: they agree to 2e-6.
// A plane in metres sampled on a geographic grid at 60 degrees north, where a sample is twice
// as tall as it is wide. Warped to a local projection the samples are square metres, and the
// plane's slopes come back in metres along both axes; unwarped, the report says how far off the
// squared samples are.
TEST(DemImport, GeographicDemWarpedToALocalProjectionHasSquareMetreSamples) {
  const fs::path dir = temp_dir();
  const int w = 120, h = 80;
  const double d = 3.0 / 3600.0, lat0 = 60.0 + 40 * d, lon0 = 10.0;
  const auto [mx, my] = wgs84_spacing(60.0, d, d);  // metres per sample at the centre
  std::vector<double> v(size_t(w * h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      v[size_t(y * w + x)] = 500.0 + 0.05 * (x - w / 2) * mx - 0.1 * (y - h / 2) * my;
  TestRaster r = single_band(w, h, GDT_Float32, v);
  r.transform = std::array<double, 6>{lon0, d, 0, lat0, 0, -d};
  r.epsg = 4326;
  write_raster(dir / "north.tif", "GTiff", r);
  const std::string path = (dir / "north.tif").string();

  auto plain = read_dem_file(path);
  ASSERT_TRUE(plain.ok()) << plain.error().describe();
  EXPECT_NEAR(plain->anisotropy, my / mx, 0.01);
  EXPECT_NE(plain->distortion.find("east-west by +41."), std::string::npos) << plain->distortion;

  for (const LocalProjection p : {LocalProjection::kAzimuthalEquidistant, LocalProjection::kUtm}) {
    SCOPED_TRACE(to_string(p));
    DemScaleOptions o;
    o.project = p;
    auto dem = read_dem_file(path, o);
    ASSERT_TRUE(dem.ok()) << dem.error().describe();
    EXPECT_DOUBLE_EQ(dem->anisotropy, 1.0);
    EXPECT_GT(dem->meters_per_sample, mx * 0.9);
    EXPECT_LT(dem->meters_per_sample, my * 1.1);
    EXPECT_NE(dem->distortion.find(p == LocalProjection::kUtm ? "UTM zone 32N" : "azimuthal equidistant"),
              std::string::npos)
        << dem->distortion;
    // The plane's slopes, per metre, along a row (east) and down a column (south), in the middle.
    const int64_t W = dem->width, H = dem->height;
    const double s = dem->meters_per_sample;
    std::vector<double> east, south;
    for (int64_t y = H / 4; y < 3 * H / 4; ++y) {
      for (int64_t x = W / 4; x < 3 * W / 4; ++x) {
        const double a = dem->meters[size_t(y * W + x)], b = dem->meters[size_t(y * W + x + 1)],
                     c = dem->meters[size_t((y + 1) * W + x)];
        if (std::isnan(a) || std::isnan(b) || std::isnan(c)) continue;
        east.push_back((b - a) / s);
        south.push_back((c - a) / s);
      }
    }
    ASSERT_GT(east.size(), 100u);
    std::nth_element(east.begin(), east.begin() + ptrdiff_t(east.size() / 2), east.end());
    std::nth_element(south.begin(), south.begin() + ptrdiff_t(south.size() / 2), south.end());
    // UTM zone 32's central meridian is 9 degrees east: its grid north turns by about a degree.
    const double tol = p == LocalProjection::kUtm ? 0.004 : 0.002;
    EXPECT_NEAR(east[east.size() / 2], 0.05, tol);
    EXPECT_NEAR(south[south.size() / 2], -0.1, tol);
    // The corners outside the warped footprint are NoData, interpolated on import.
    auto imported = import_dem(*dem);
    ASSERT_TRUE(imported.ok()) << imported.error().describe();
    EXPECT_NE(imported->report.summary().find("distortion"), std::string::npos);
  }
  // Only a geographic raster is projected, and only by its georeferencing.
  DemScaleOptions both;
  both.project = LocalProjection::kAzimuthalEquidistant;
  both.meters_per_sample = 30.0;
  auto refused = read_dem_file(path, both);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().describe().find("--meters-per-sample"), std::string::npos)
      << refused.error().describe();
  TestRaster utm = single_band(16, 8, GDT_Float32, std::vector<double>(16 * 8, 10.0));
  utm.transform = std::array<double, 6>{500000, 30, 0, 5000000, 0, -30};
  utm.epsg = 32633;
  write_raster(dir / "utm.tif", "GTiff", utm);
  DemScaleOptions project;
  project.project = LocalProjection::kUtm;
  auto projected = read_dem_file((dir / "utm.tif").string(), project);
  ASSERT_FALSE(projected.ok());
  EXPECT_NE(projected.error().describe().find("geographic"), std::string::npos)
      << projected.error().describe();
  fs::remove_all(dir);
}

TEST(DemImport, GeographicSpacingMatchesTheEtopo5Sidecar) {
  const fs::path dir = temp_dir();
  const double west = -0.041667052558462606, east = 359.9616670525584;
  const double north = 90.04166666666667, south = -90.04166666666664;
  const double dx = (east - west) / 4320, dy = (north - south) / 2161;
  TestRaster r = single_band(8, 6, GDT_UInt16, std::vector<double>(48, 7.0));
  r.bands[0].values[3] = 9.0;
  r.transform = std::array<double, 6>{west, dx, 0, 3 * dy, 0, -dy};  // centred on the equator
  r.epsg = 4326;
  write_raster(dir / "etopo_like.tif", "GTiff", r);
  auto dem = read_dem_file((dir / "etopo_like.tif").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  const double x = 9276.697581106737, y = 9214.522916666665;  // etopo5_global_4320x2161.json
  EXPECT_NEAR(dem->meters_per_sample, std::sqrt(x * y), 2e-6 * std::sqrt(x * y));
  EXPECT_NEAR(dem->anisotropy, y / x, 2e-6);
  fs::remove_all(dir);
}

TEST(DemImport, GeographicCrsWithATransformNotInDegreesIsAnErrorNamingTheCrs) {
  const fs::path dir = temp_dir();
  TestRaster r = single_band(40, 30, GDT_Float32, rough_terrain(40, 30, 2));
  r.transform = std::array<double, 6>{600000, 30, 0, 5200000, 0, -30};  // metres, labelled degrees
  r.epsg = 4326;
  write_raster(dir / "mislabelled.tif", "GTiff", r);
  const std::string why = expect_refused(dir / "mislabelled.tif");
  EXPECT_NE(why.find("WGS 84"), std::string::npos) << why;
  EXPECT_NE(why.find("latitude"), std::string::npos) << why;
  // Naming the spacing reads it.
  DemScaleOptions o;
  o.meters_per_sample = 30;
  EXPECT_TRUE(read_dem_file((dir / "mislabelled.tif").string(), o).ok());
  fs::remove_all(dir);
}

TEST(DemImport, ProjectedCrsInUsFeetBecomesMetres) {
  const fs::path dir = temp_dir();
  TestRaster r = single_band(33, 21, GDT_Float32, rough_terrain(33, 21, 4));
  r.transform = std::array<double, 6>{6500000, 10, 0, 1900000, 0, -10};
  r.epsg = 2229;  // NAD83 / California zone 5 (ftUS)
  write_raster(dir / "feet.tif", "GTiff", r);
  auto dem = read_dem_file((dir / "feet.tif").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  EXPECT_NEAR(dem->meters_per_sample, 10 * 1200.0 / 3937.0, 1e-9);
  EXPECT_NE(dem->scale_note.find("foot"), std::string::npos) << dem->scale_note;
  fs::remove_all(dir);
}

TEST(DemImport, ReadsCloudOptimizedGeoTiff) {
  const fs::path dir = temp_dir();
  const std::vector<double> v = rough_terrain(700, 600, 21);
  TestRaster r = single_band(700, 600, GDT_Int16, v);
  r.transform = std::array<double, 6>{400000, 5, 0, 5000000, 0, -5};
  r.epsg = 32632;
  r.creation_options = {"COMPRESS=DEFLATE", "BLOCKSIZE=256"};
  write_raster(dir / "cog.tif", "COG", r);
  auto dem = read_dem_file((dir / "cog.tif").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  EXPECT_EQ(dem->format, "GTiff");
  EXPECT_DOUBLE_EQ(dem->meters_per_sample, 5.0);
  EXPECT_EQ(dem->meters, v);
  fs::remove_all(dir);
}

TEST(DemImport, ReadsSrtmHgt) {
  const fs::path dir = temp_dir();
  const int n = 1201;
  const std::vector<double> v = rough_terrain(n, n, 7, 1800.0);
  std::vector<uint8_t> bytes;
  bytes.reserve(size_t(n) * n * 2);
  for (size_t i = 0; i < v.size(); ++i) {
    const int16_t s = i == 5000 ? int16_t(-32768) : int16_t(v[i]);  // one void
    bytes.push_back(uint8_t(uint16_t(s) >> 8));
    bytes.push_back(uint8_t(uint16_t(s)));
  }
  write_bytes(dir / "N47E011.hgt", bytes);
  auto dem = read_dem_file((dir / "N47E011.hgt").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  EXPECT_EQ(dem->format, "SRTMHGT");
  EXPECT_EQ(dem->width, n);
  EXPECT_EQ(dem->height, n);
  EXPECT_EQ(dem->nodata_count, 1);
  EXPECT_TRUE(std::isnan(dem->meters[5000]));
  EXPECT_EQ(dem->meters[12345], v[12345]);
  const auto [x, y] = wgs84_spacing(47.5, 1.0 / 1200, 1.0 / 1200);
  EXPECT_NEAR(dem->meters_per_sample, std::sqrt(x * y), 1e-6);
  auto w = import_dem(*dem);
  ASSERT_TRUE(w.ok()) << w.error().describe();
  EXPECT_TRUE(w->report.exact);
  fs::remove_all(dir);
}

TEST(DemImport, ReadsEsriAsciiGrid) {
  const fs::path dir = temp_dir();
  const int w = 37, h = 23;
  std::ofstream out(dir / "grid.asc");
  out << "ncols " << w << "\nnrows " << h << "\nxllcorner 1000\nyllcorner 2000\ncellsize 25\n"
      << "NODATA_value -9999\n";
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) out << (x == 3 && y == 4 ? -9999.0 : 100.0 + x * 0.5 + y * 0.25) << ' ';
    out << '\n';
  }
  out.close();
  auto dem = read_dem_file((dir / "grid.asc").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  EXPECT_EQ(dem->format, "AAIGrid");
  EXPECT_EQ(dem->width, w);
  EXPECT_EQ(dem->height, h);
  EXPECT_DOUBLE_EQ(dem->meters_per_sample, 25.0);  // no .prj: the cell size is taken as metres
  EXPECT_EQ(dem->nodata_count, 1);
  EXPECT_TRUE(std::isnan(dem->meters[size_t(4 * w + 3)]));
  EXPECT_DOUBLE_EQ(dem->meters[size_t(2 * w + 10)], 100.0 + 10 * 0.5 + 2 * 0.25);  // row 0 = north
  fs::remove_all(dir);
}

// A cell GDAL's reader would take as 0 is refused, from a file and from memory, with its row
// and column; a clean grid beside it still reads.
TEST(DemImport, AsciiGridCellThatIsNotANumberIsRefusedNamingItsRowAndColumn) {
  const fs::path dir = temp_dir();
  const std::string header = "ncols 5\nnrows 4\nxllcorner 0\nyllcorner 0\ncellsize 10\nNODATA_value -9999\n";
  std::ofstream(dir / "banana.asc") << header
                                    << "1 2 3 4 5\n6 7 8 9 10\n11 12 banana 14 15\n16 17 18 19 20\n";
  auto dem = read_dem_file((dir / "banana.asc").string());
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kCorrupt);
  EXPECT_EQ(dem.error().describe(),
            (dir / "banana.asc").string() + ": row 3, column 3 (line 9): 'banana' is not a number");
  auto strips = open_dem_strips((dir / "banana.asc").string());
  ASSERT_FALSE(strips.ok());
  EXPECT_NE(strips.error().message.find("row 3, column 3"), std::string::npos) << strips.error().describe();
  const auto bytes = read_bytes(dir / "banana.asc");
  auto mem = read_dem_memory(bytes, "banana.asc", "");
  ASSERT_FALSE(mem.ok());
  EXPECT_EQ(mem.error().describe(), "banana.asc: row 3, column 3 (line 9): 'banana' is not a number");
  // Through a VRT the grid is checked the same way.
  std::ofstream(dir / "over.vrt")
      << "<VRTDataset rasterXSize=\"5\" rasterYSize=\"4\"><VRTRasterBand "
         "dataType=\"Float32\" band=\"1\"><SimpleSource><SourceFilename "
         "relativeToVRT=\"1\">banana.asc</SourceFilename><SourceBand>1</SourceBand>"
         "</SimpleSource></VRTRasterBand></VRTDataset>";
  auto through = read_dem_file((dir / "over.vrt").string());
  ASSERT_FALSE(through.ok());
  EXPECT_NE(through.error().describe().find("its source banana.asc"), std::string::npos)
      << through.error().describe();
  EXPECT_NE(through.error().describe().find("row 3, column 3"), std::string::npos)
      << through.error().describe();
  std::ofstream(dir / "clean.asc") << header << "1 2 3 4 5\n6 7 8 9 10\n11 12 13 14 15\n16 17 18 19 -9999\n";
  auto clean = read_dem_file((dir / "clean.asc").string());
  ASSERT_TRUE(clean.ok()) << clean.error().describe();
  EXPECT_DOUBLE_EQ(clean->meters[12], 13.0);
  EXPECT_EQ(clean->nodata_count, 1);
  fs::remove_all(dir);
}

// A raster whose geotransform runs south-up (positive row step) or east-left (negative column
// step) is the same terrain as its north-up twin: read flipped, sample for sample, whole and in
// strips of any height, and the import says what it turned.
TEST(DemImport, SouthUpAndEastLeftGeoTiffsReadExactlyAsTheirNorthUpTwin) {
  const fs::path dir = temp_dir();
  const int w = 53, h = 41;
  const std::vector<double> north_up = rough_terrain(w, h, 23);
  TestRaster r = single_band(w, h, GDT_Int16, north_up);
  r.transform = std::array<double, 6>{500000.0, 30.0, 0, 4100000.0 + 30.0 * h, 0, -30.0};
  r.epsg = 32613;
  write_raster(dir / "north.tif", "GTiff", r);
  const struct {
    const char* name;
    bool flip_rows, flip_columns;
    const char* orientation;
  } cases[] = {
      {"south.tif", true, false, "south-up (rows flipped)"},
      {"east_left.tif", false, true, "east-left (columns flipped)"},
      {"both.tif", true, true, "south-up and east-left (rows and columns flipped)"},
  };
  auto north = read_dem_file((dir / "north.tif").string());
  ASSERT_TRUE(north.ok()) << north.error().describe();
  EXPECT_EQ(north->orientation, "north-up");
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    // The file stores the rows and columns in its own order; its transform says so.
    std::vector<double> stored(north_up.size());
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const int sy = c.flip_rows ? h - 1 - y : y, sx = c.flip_columns ? w - 1 - x : x;
        stored[size_t(sy * w + sx)] = north_up[size_t(y * w + x)];
      }
    }
    TestRaster f = single_band(w, h, GDT_Int16, stored);
    f.transform = std::array<double, 6>{c.flip_columns ? 500000.0 + 30.0 * w : 500000.0,
                                        c.flip_columns ? -30.0 : 30.0,
                                        0,
                                        c.flip_rows ? 4100000.0 : 4100000.0 + 30.0 * h,
                                        0,
                                        c.flip_rows ? 30.0 : -30.0};
    f.epsg = 32613;
    write_raster(dir / c.name, "GTiff", f);
    auto dem = read_dem_file((dir / c.name).string());
    ASSERT_TRUE(dem.ok()) << dem.error().describe();
    EXPECT_EQ(dem->orientation, c.orientation);
    EXPECT_EQ(dem->meters, north->meters);
    EXPECT_DOUBLE_EQ(dem->meters_per_sample, 30.0);
    // Strips of 1, 7 and 41 rows at any start give the same rows.
    auto strips = open_dem_strips((dir / c.name).string());
    ASSERT_TRUE(strips.ok()) << strips.error().describe();
    for (const int rows : {1, 7, h}) {
      for (int y0 = 0; y0 + rows <= h; y0 += 5) {
        std::vector<double> got(size_t(rows * w));
        ASSERT_TRUE(strips->read_rows(y0, rows, got).ok());
        ASSERT_TRUE(std::equal(got.begin(), got.end(), north->meters.begin() + y0 * w)) << y0 << "+" << rows;
      }
    }
    auto imported = import_dem(*dem);
    ASSERT_TRUE(imported.ok()) << imported.error().describe();
    EXPECT_EQ(imported->report.orientation, c.orientation);
    EXPECT_NE(imported->report.summary().find(std::string("orientation       ") + c.orientation),
              std::string::npos)
        << imported->report.summary();
  }
  fs::remove_all(dir);
}

// A rotated or sheared geotransform would need resampling: refused, naming the steps and the
// gdalwarp command that makes the raster north-up. Rounding-sized rotation terms are not a
// rotation.
TEST(DemImport, RotatedGeoTransformIsRefusedWithTheCommandThatMakesItNorthUp) {
  const fs::path dir = temp_dir();
  const int w = 30, h = 20;
  TestRaster r = single_band(w, h, GDT_Float32, rough_terrain(w, h, 4));
  const double c = std::cos(0.3) * 10.0, s = std::sin(0.3) * 10.0;
  r.transform = std::array<double, 6>{1000.0, c, -s, 2000.0, -s, -c};
  write_raster(dir / "rotated.tif", "GTiff", r);
  auto dem = read_dem_file((dir / "rotated.tif").string());
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(dem.error().message.find("rotated or sheared"), std::string::npos) << dem.error().describe();
  EXPECT_NE(dem.error().message.find("gdalwarp " + (dir / "rotated.tif").string()), std::string::npos)
      << dem.error().describe();
  EXPECT_FALSE(open_dem_strips((dir / "rotated.tif").string()).ok());
  r.transform = std::array<double, 6>{1000.0, 10.0, 1e-12, 2000.0, -1e-12, -10.0};
  write_raster(dir / "nearly.tif", "GTiff", r);
  auto nearly = read_dem_file((dir / "nearly.tif").string());
  ASSERT_TRUE(nearly.ok()) << nearly.error().describe();
  EXPECT_EQ(nearly->orientation, "north-up");
  fs::remove_all(dir);
}

TEST(DemImport, ReadsVrt) {
  const fs::path dir = temp_dir();
  const std::vector<double> v = rough_terrain(50, 40, 9);
  TestRaster r = single_band(50, 40, GDT_Int16, v);
  write_raster(dir / "src.tif", "GTiff", r);
  // A 20x10 window of src.tif starting at (5, 7).
  std::ofstream(dir / "window.vrt") << R"(<VRTDataset rasterXSize="20" rasterYSize="10">
  <GeoTransform>300000, 5, 0, 4000000, 0, -5</GeoTransform>
  <VRTRasterBand dataType="Int16" band="1">
    <SimpleSource>
      <SourceFilename relativeToVRT="1">src.tif</SourceFilename>
      <SourceBand>1</SourceBand>
      <SrcRect xOff="5" yOff="7" xSize="20" ySize="10"/>
      <DstRect xOff="0" yOff="0" xSize="20" ySize="10"/>
    </SimpleSource>
  </VRTRasterBand>
</VRTDataset>
)";
  auto dem = read_dem_file((dir / "window.vrt").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  EXPECT_EQ(dem->format, "VRT");
  ASSERT_EQ(dem->width, 20);
  ASSERT_EQ(dem->height, 10);
  EXPECT_DOUBLE_EQ(dem->meters_per_sample, 5.0);
  for (int y = 0; y < 10; ++y) {
    for (int x = 0; x < 20; ++x) ASSERT_EQ(dem->meters[size_t(y * 20 + x)], v[size_t((y + 7) * 50 + x + 5)]);
  }
  fs::remove_all(dir);
}

// A VRT may not read arbitrary files as raw samples (say /etc/passwd or /dev/zero), nor hide
// such a VRT inside another.
TEST(DemImport, VrtRawBandOverAnyFileIsRefused) {
  const fs::path dir = temp_dir();
  std::ofstream(dir / "raw.vrt") << R"(<VRTDataset rasterXSize="16" rasterYSize="4">
  <VRTRasterBand dataType="Byte" band="1" subClass="VRTRawRasterBand">
    <SourceFilename relativetoVRT="0">/etc/passwd</SourceFilename>
    <ImageOffset>0</ImageOffset><PixelOffset>1</PixelOffset><LineOffset>16</LineOffset>
  </VRTRasterBand>
</VRTDataset>
)";
  std::string why = expect_refused(dir / "raw.vrt");
  EXPECT_NE(why.find("VRTRawRasterBand"), std::string::npos) << why;
  // Nor a VRT of VRTs, which would hide one.
  std::ofstream(dir / "outer.vrt") << R"(<VRTDataset rasterXSize="16" rasterYSize="4">
  <VRTRasterBand dataType="Byte" band="1"><SimpleSource>
    <SourceFilename relativeToVRT="1">raw.vrt</SourceFilename><SourceBand>1</SourceBand>
  </SimpleSource></VRTRasterBand>
</VRTDataset>
)";
  why = expect_refused(dir / "outer.vrt");
  EXPECT_NE(why.find("sources are VRTs"), std::string::npos) << why;
  fs::remove_all(dir);
}

TEST(DemImport, NoDataScaleOffsetFromBand) {
  const fs::path dir = temp_dir();
  std::vector<double> raw(29 * 17);
  for (size_t i = 0; i < raw.size(); ++i) raw[i] = double(i % 400);
  raw[7] = -1;
  TestRaster r = single_band(29, 17, GDT_Int16, raw);
  r.bands[0].nodata = -1;
  r.bands[0].scale = 0.25;
  r.bands[0].offset = 100;
  write_raster(dir / "scaled.tif", "GTiff", r);
  auto dem = read_dem_file((dir / "scaled.tif").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  EXPECT_EQ(dem->nodata_count, 1);
  EXPECT_TRUE(std::isnan(dem->meters[7]));
  EXPECT_DOUBLE_EQ(dem->meters[100], 100 + 0.25 * 100);
  EXPECT_DOUBLE_EQ(dem->vertical_step, 0.25);
  auto w = import_dem(*dem);
  ASSERT_TRUE(w.ok());
  EXPECT_TRUE(w->report.exact) << "an integer band with a power-of-two scale imports exactly";
  // A band in feet becomes metres.
  TestRaster ft = single_band(8, 8, GDT_Float32, std::vector<double>(64, 1000.0));
  ft.bands[0].unit = "ft";
  ft.bands[0].values[0] = 10.0;
  write_raster(dir / "feet.tif", "GTiff", ft);
  auto feet = read_dem_file((dir / "feet.tif").string());
  ASSERT_TRUE(feet.ok()) << feet.error().describe();
  EXPECT_DOUBLE_EQ(feet->meters[1], 304.8);
  fs::remove_all(dir);
}

TEST(DemImport, FloatDemsOfOddSizesReadExactly) {
  const fs::path dir = temp_dir();
  for (const auto& [w, h] : std::vector<std::pair<int, int>>{{2, 2}, {3, 257}, {301, 5}, {513, 129}}) {
    std::vector<double> v = rough_terrain(w, h, uint32_t(w * 1000 + h), -200.0);
    for (size_t i = 0; i < v.size(); ++i) v[i] = double(float(v[i] + 0.1 * double(i % 7)));
    write_raster(dir / "f.tif", "GTiff", single_band(w, h, GDT_Float32, v));
    auto dem = read_dem_file((dir / "f.tif").string());
    ASSERT_TRUE(dem.ok()) << dem.error().describe();
    ASSERT_EQ(dem->meters, v) << w << "x" << h;
    EXPECT_FALSE(dem->integer_source);
  }
  // Flat terrain imports too (a zero range gets a minimal one).
  write_raster(dir / "flat.tif", "GTiff",
               single_band(64, 48, GDT_Float32, std::vector<double>(64 * 48, 12.5)));
  auto flat = read_dem_file((dir / "flat.tif").string());
  ASSERT_TRUE(flat.ok()) << flat.error().describe();
  auto w = import_dem(*flat);
  ASSERT_TRUE(w.ok()) << w.error().describe();
  EXPECT_NEAR(w->report.max_m, 12.5, 1e-12);
  fs::remove_all(dir);
}

// The bug: a TIFF truncated to 7% of its bytes imported with rows of zeros and exit 0.
TEST(DemImport, TruncatedTiffIsRefused) {
  const fs::path dir = temp_dir();
  const std::vector<double> v = rough_terrain(512, 512, 5);
  for (const char* compress : {"COMPRESS=NONE", "COMPRESS=DEFLATE"}) {
    TestRaster r = single_band(512, 512, GDT_UInt16, v);
    r.creation_options = {compress};
    write_raster(dir / "whole.tif", "GTiff", r);
    auto bytes = read_bytes(dir / "whole.tif");
    ASSERT_TRUE(read_dem_file((dir / "whole.tif").string()).ok());
    bytes.resize(bytes.size() * 7 / 100);
    write_bytes(dir / "cut.tif", bytes);
    const std::string why = expect_refused(dir / "cut.tif");
    EXPECT_NE(why.find("cut.tif"), std::string::npos) << why;
    EXPECT_NE(why.find("truncated or corrupt"), std::string::npos) << compress << ": " << why;
  }
  fs::remove_all(dir);
}

TEST(DemImport, GdalErrorsBecomeTheMessageAndAreNotPrinted) {
  const fs::path dir = temp_dir();
  write_bytes(dir / "cut.tif", tiff_claiming(600, 400, 5000));
  ::testing::internal::CaptureStderr();
  auto r = read_dem_file((dir / "cut.tif").string());
  const std::string printed = ::testing::internal::GetCapturedStderr();
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(printed, "");
  EXPECT_EQ(r.error().code, ErrorCode::kCorrupt);
  EXPECT_NE(r.error().describe().find("rows 0.."), std::string::npos) << r.error().describe();
  fs::remove_all(dir);
}

// The bug: a 1 KB PNG claiming 30000x30000 allocated 7 GB and died with std::bad_alloc.
TEST(DemImport, HeaderClaimingHugeSizeFailsWithoutAllocating) {
  const fs::path dir = temp_dir();
  struct Case {
    const char* name;
    std::vector<uint8_t> bytes;
    ErrorCode code;
  };
  const std::vector<Case> cases = {
      {"huge.png", png_claiming(30000, 30000), ErrorCode::kOversize},
      {"under_cap.png", png_claiming(16000, 16000), ErrorCode::kCorrupt},
      {"huge.tif", tiff_claiming(30000, 30000, 800), ErrorCode::kOversize},
      {"under_cap.tif", tiff_claiming(16000, 16000, 800), ErrorCode::kCorrupt},
      {"wide.tif", tiff_claiming(2000000, 2, 800), ErrorCode::kOversize},
  };
  for (const Case& c : cases) {
    ASSERT_LT(c.bytes.size(), 1200u);
    write_bytes(dir / c.name, c.bytes);
    auto r = read_dem_file((dir / c.name).string());
    ASSERT_FALSE(r.ok()) << c.name;
    EXPECT_EQ(r.error().code, c.code) << c.name << ": " << r.error().describe();
    if (c.code == ErrorCode::kOversize) {
      EXPECT_NE(r.error().describe().find("cap"), std::string::npos) << r.error().describe();
    }
  }
  // Memory follows the data read (a few strips at most), not the 512 MB to 1.8 GB claimed.
  const std::optional<int> growth_mb = child_peak_growth_mb([&] {
    bool all_refused = true;
    for (const Case& c : cases) all_refused = all_refused && !read_dem_file((dir / c.name).string()).ok();
    return all_refused;
  });
  ASSERT_TRUE(growth_mb) << "the child reading the files failed";
  EXPECT_LT(*growth_mb, 64);
  fs::remove_all(dir);
}

TEST(DemImport, RgbImageIsRefusedUnlessBandNamed) {
  const fs::path dir = temp_dir();
  const int w = 40, h = 30;
  auto channel = [&](double k) {
    std::vector<double> v(size_t(w * h));
    for (size_t i = 0; i < v.size(); ++i) v[i] = double((i * size_t(k)) % 256);
    return v;
  };
  struct Case {
    const char* name;
    std::vector<GDALColorInterp> colors;
    const char* kind;
  };
  const std::vector<Case> cases = {
      {"rgb.png", {GCI_RedBand, GCI_GreenBand, GCI_BlueBand}, "RGB"},
      {"rgba.png", {GCI_RedBand, GCI_GreenBand, GCI_BlueBand, GCI_AlphaBand}, "RGBA"},
      {"graya.png", {GCI_GrayIndex, GCI_AlphaBand}, "gray+alpha"},
  };
  for (const Case& c : cases) {
    TestRaster r;
    r.width = w;
    r.height = h;
    r.type = GDT_Byte;
    for (size_t b = 0; b < c.colors.size(); ++b)
      r.bands.push_back(band_of(channel(double(b + 3)), c.colors[b]));
    write_raster(dir / c.name, "PNG", r);
    const std::string why = expect_refused(dir / c.name);
    EXPECT_NE(why.find(std::string(" ") + c.kind + " image"), std::string::npos) << why;
    EXPECT_NE(why.find("--band"), std::string::npos) << why;
    DemScaleOptions named;
    named.band = 2;
    auto dem = read_dem_file((dir / c.name).string(), named);
    ASSERT_TRUE(dem.ok()) << dem.error().describe();
    EXPECT_EQ(dem->band, 2);
    EXPECT_EQ(dem->meters[10], r.bands[1].values[10]);
    named.band = int(c.colors.size()) + 1;
    EXPECT_NE(expect_refused(dir / c.name, named).find("--band"), std::string::npos);
  }
  fs::remove_all(dir);
}

TEST(DemImport, SidecarWithWrongDimensionsIsAnError) {
  const fs::path dir = temp_dir();
  fs::copy_file(fs::path(LOAM_SOURCE_DIR) / "data" / "default_terrain.png", dir / "t.png");
  std::ofstream(dir / "t.json") << R"({"width": 1000, "height": 768, "sample_type": "uint16",
    "meters_per_sample_xy": [2, 2], "height_scale_m": 0.02, "height_offset_m": 0})";
  std::string why = expect_refused(dir / "t.png");
  EXPECT_NE(why.find("1000x768"), std::string::npos) << why;
  EXPECT_NE(why.find("1024x768"), std::string::npos) << why;
  EXPECT_NE(why.find("sidecar"), std::string::npos) << why;
  fs::remove_all(dir);
}

TEST(DemImport, SidecarWithWrongSampleTypeOrValueTypesIsAnError) {
  const fs::path dir = temp_dir();
  fs::copy_file(fs::path(LOAM_SOURCE_DIR) / "data" / "default_terrain.png", dir / "t.png");
  std::ofstream(dir / "t.json") << R"({"width": 1024, "height": 768, "sample_type": "float32"})";
  std::string why = expect_refused(dir / "t.png");
  EXPECT_NE(why.find("float32"), std::string::npos) << why;
  EXPECT_NE(why.find("uint16"), std::string::npos) << why;
  std::ofstream(dir / "t.json") << R"({"height_scale_m": "0.02"})";
  why = expect_refused(dir / "t.png");
  EXPECT_NE(why.find("height_scale_m"), std::string::npos) << why;
  std::ofstream(dir / "t.json") << R"({"meters_per_sample_xy": [2, -2]})";
  why = expect_refused(dir / "t.png");
  EXPECT_NE(why.find("meters_per_sample_xy"), std::string::npos) << why;
  // A Loam world sidecar whose tiles do not cover the image.
  std::ofstream(dir / "t.json") << R"({"loam_world": {"meters_per_sample": 2, "height_offset": 0,
    "meters_per_unit": 0.01, "detail_factor": 4, "detail_meters_per_unit": 0.0025, "origin_tile_x": 0,
    "origin_tile_y": 0, "tiles_x": 5, "tiles_y": 3}})";
  why = expect_refused(dir / "t.png");
  EXPECT_NE(why.find("5x3 tiles"), std::string::npos) << why;
  fs::remove_all(dir);
}

// The bug: a DEM smaller than a tile was padded by repeating its edge samples, streaks that
// filled the rest of the world.
TEST(DemImport, SmallDemIsPaddedWithFlatApron) {
  const fs::path dir = temp_dir();
  const int w = 37, h = 23;
  std::vector<double> v(size_t(w * h));
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) v[size_t(y * w + x)] = 50.0 + 2.0 * x + 3.0 * y;  // a tilted plane
  }
  write_raster(dir / "small.tif", "GTiff", single_band(w, h, GDT_Float32, v));
  auto dem = read_dem_file((dir / "small.tif").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  auto imported = import_dem(*dem);
  ASSERT_TRUE(imported.ok()) << imported.error().describe();
  const World& world = imported->world;
  const ImportReport& r = imported->report;
  EXPECT_EQ(r.tiles_x, 1);
  EXPECT_EQ(r.tiles_y, 1);
  EXPECT_TRUE(r.padded);
  double border = 0;
  int n = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (x == 0 || y == 0 || x == w - 1 || y == h - 1) {
        border += v[size_t(y * w + x)];
        ++n;
      }
    }
  }
  const uint16_t apron = quantize_height(world.params(), border / n);
  EXPECT_NEAR(r.apron_m, border / n, r.meters_per_unit);
  for (int64_t y = 0; y < kTileSize; ++y) {
    for (int64_t x = 0; x < kTileSize; ++x) {
      if (x < w && y < h) {
        ASSERT_EQ(world.coarse(x, y), quantize_height(world.params(), v[size_t(y * w + x)]));
      } else {
        ASSERT_EQ(world.coarse(x, y), apron) << "padding at " << x << "," << y << " is not the flat apron";
      }
    }
  }
  fs::remove_all(dir);
}

// Random damage to a GeoTIFF's bytes gives an Error or a raster, never a crash or a read out of
// bounds (ASan watches the reads Loam makes).
TEST(DemImport, CorruptTiffBytesNeverCrashTheReader) {
  const fs::path dir = temp_dir();
  TestRaster r = single_band(24, 16, GDT_Float32, rough_terrain(24, 16, 3));
  r.bands[0].nodata = -9999;
  r.transform = std::array<double, 6>{0, 2, 0, 0, 0, -2};
  r.epsg = 32633;
  write_raster(dir / "good.tif", "GTiff", r);
  const auto good = read_bytes(dir / "good.tif");
  std::mt19937 rng(5);
  int refused = 0;
  for (int round = 0; round < 400; ++round) {
    auto bad = good;
    const int flips = 1 + int(rng() % 4);
    for (int i = 0; i < flips; ++i) bad[rng() % std::min<size_t>(bad.size(), 400)] = uint8_t(rng());
    if (round % 7 == 0) bad.resize(1 + rng() % (bad.size() - 1));
    auto got = read_dem_memory(bad, "bad.tif", "");
    refused += got.ok() ? 0 : 1;
  }
  EXPECT_GT(refused, 0);
  fs::remove_all(dir);
}

// The same for PNG and ESRI ASCII grid bytes, read from memory like the default terrain.
TEST(DemImport, CorruptPngAndAsciiGridBytesNeverCrashTheReader) {
  const fs::path dir = temp_dir();
  write_raster(dir / "good.png", "PNG", single_band(40, 30, GDT_UInt16, rough_terrain(40, 30, 8)));
  std::ofstream(dir / "good.asc")
      << "ncols 5\nnrows 4\nxllcorner 0\nyllcorner 0\ncellsize 10\n"
      << "NODATA_value -9999\n1 2 3 4 5\n6 7 8 9 10\n11 12 13 14 15\n16 17 18 19 20\n";
  std::mt19937 rng(17);
  for (const char* name : {"good.png", "good.asc"}) {
    const auto good = read_bytes(dir / name);
    ASSERT_TRUE(read_dem_memory(good, name, "").ok()) << name;
    for (int round = 0; round < 300; ++round) {
      auto bad = good;
      const int flips = 1 + int(rng() % 4);
      for (int i = 0; i < flips; ++i) bad[rng() % bad.size()] = uint8_t(rng());
      if (round % 5 == 0) bad.resize(1 + rng() % (bad.size() - 1));
      (void)read_dem_memory(bad, name, "");  // an Error or a raster, never a crash
    }
  }
  fs::remove_all(dir);
}

TEST(DemImport, NanOnlyFloatTiffIsRefused) {
  const fs::path dir = temp_dir();
  write_raster(dir / "nan.tif", "GTiff", single_band(9, 7, GDT_Float32, std::vector<double>(63, NAN)));
  const std::string why = expect_refused(dir / "nan.tif");
  EXPECT_NE(why.find("NaN or NoData"), std::string::npos) << why;
  fs::remove_all(dir);
}

struct BadFile {
  const char* name;
  std::vector<uint8_t> bytes;
  ErrorCode code;
  const char* reason;
};

TEST(DemImport, EveryBadFileGivesAnErrorNamingTheFileAndTheReason) {
  const fs::path dir = temp_dir();
  const auto png = read_bytes(fs::path(LOAM_SOURCE_DIR) / "data" / "default_terrain.png");
  ASSERT_GT(png.size(), 1000u);
  std::vector<BadFile> cases = {
      {"empty.png", {}, ErrorCode::kInvalidArgument, "empty"},
      {"garbage.png", {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12}, ErrorCode::kCorrupt, "cannot decode"},
      {"truncated.png", std::vector<uint8_t>(png.begin(), png.begin() + 2000), ErrorCode::kCorrupt, ""},
      {"terrain.bmp", png, ErrorCode::kUnsupported, "unsupported format"},
      {"noextension", png, ErrorCode::kUnsupported, "extension"},
  };
  for (const auto& c : cases) {
    write_bytes(dir / c.name, c.bytes);
    auto r = read_dem_file((dir / c.name).string());
    ASSERT_FALSE(r.ok()) << c.name;
    EXPECT_EQ(r.error().code, c.code) << c.name << ": " << r.error().describe();
    EXPECT_NE(r.error().describe().find(c.name), std::string::npos) << r.error().describe();
    EXPECT_NE(r.error().describe().find(c.reason), std::string::npos) << r.error().describe();
  }
  // Missing file.
  auto missing = read_dem_file((dir / "missing.png").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
  // NaN-only float image.
  write_float_image(dir / "nan.exr", 8, 8, std::vector<float>(64, std::nanf("")));
  auto nan = read_dem_file((dir / "nan.exr").string());
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.error().describe().find("NaN"), std::string::npos) << nan.error().describe();
  // 1x1 image.
  write_float_image(dir / "one.exr", 1, 1, {5.0f});
  auto one = read_dem_file((dir / "one.exr").string());
  ASSERT_FALSE(one.ok());
  EXPECT_NE(one.error().describe().find("2x2"), std::string::npos) << one.error().describe();
  // Corrupt sidecar.
  fs::copy_file(fs::path(LOAM_SOURCE_DIR) / "data" / "default_terrain.png", dir / "side.png");
  std::ofstream(dir / "side.json") << "{ not json";
  auto side = read_dem_file((dir / "side.png").string());
  ASSERT_FALSE(side.ok());
  EXPECT_EQ(side.error().code, ErrorCode::kCorrupt);
  EXPECT_NE(side.error().describe().find("sidecar"), std::string::npos);
  // Absurd explicit scale.
  DemScaleOptions absurd;
  absurd.meters_per_sample = -3;
  auto neg = read_dem_file((fs::path(LOAM_SOURCE_DIR) / "data" / "default_terrain.png").string(), absurd);
  ASSERT_FALSE(neg.ok());
  EXPECT_NE(neg.error().describe().find("meters per sample"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace loam
