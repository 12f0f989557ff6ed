#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "dem/default_terrain.h"
#include "dem/dem_export.h"
#include "dem/dem_import.h"
#include "dem/dem_raster.h"
#include "dem/tiff_tags.h"

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
  auto out = OIIO::ImageOutput::create(path.string());
  ASSERT_TRUE(out);
  ASSERT_TRUE(out->open(path.string(), OIIO::ImageSpec(w, h, 1, OIIO::TypeDesc::FLOAT)));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, px.data()));
  ASSERT_TRUE(out->close());
}

// A minimal little-endian float TIFF with GDAL_NODATA and ModelPixelScale tags, built by hand
// because OpenImageIO does not write GDAL's tags.
std::vector<uint8_t> make_geotiff(int w, int h, const std::vector<float>& px, const char* nodata,
                                  double scale) {
  std::vector<uint8_t> b;
  auto u16 = [&](uint16_t v) {
    b.push_back(uint8_t(v));
    b.push_back(uint8_t(v >> 8));
  };
  auto u32 = [&](uint32_t v) {
    for (int i = 0; i < 4; ++i) b.push_back(uint8_t(v >> (8 * i)));
  };
  const uint32_t ntags = 12, ifd = 8;
  const uint32_t extra = ifd + 2 + ntags * 12 + 4;  // after the directory
  const uint32_t nodata_len = uint32_t(std::strlen(nodata) + 1);
  const uint32_t scale_at = extra, nodata_at = scale_at + 24, data_at = nodata_at + ((nodata_len + 1) & ~1u);
  const uint32_t data_bytes = uint32_t(px.size() * 4);
  b.insert(b.end(), {'I', 'I'});
  u16(42);
  u32(ifd);
  u16(uint16_t(ntags));
  auto tag = [&](uint16_t t, uint16_t type, uint32_t count, uint32_t value) {
    u16(t);
    u16(type);
    u32(count);
    u32(value);
  };
  tag(256, 4, 1, uint32_t(w));
  tag(257, 4, 1, uint32_t(h));
  tag(258, 3, 1, 32);
  tag(259, 3, 1, 1);
  tag(262, 3, 1, 1);
  tag(273, 4, 1, data_at);
  tag(277, 3, 1, 1);
  tag(278, 4, 1, uint32_t(h));
  tag(279, 4, 1, data_bytes);
  tag(339, 3, 1, 3);
  tag(33550, 12, 3, scale_at);
  tag(42113, 2, nodata_len, nodata_at);
  u32(0);
  for (double d : {scale, scale, 0.0}) {
    uint64_t bits;
    std::memcpy(&bits, &d, 8);
    for (int i = 0; i < 8; ++i) b.push_back(uint8_t(bits >> (8 * i)));
  }
  for (uint32_t i = 0; i < nodata_len; ++i) b.push_back(uint8_t(nodata[i]));
  while (b.size() < data_at) b.push_back(0);
  const auto* p = reinterpret_cast<const uint8_t*>(px.data());
  b.insert(b.end(), p, p + data_bytes);
  return b;
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
  // Padding repeats the edge samples.
  EXPECT_EQ(w->world.coarse(299, 10), w->world.coarse(400, 10));
  fs::remove_all(dir);
}

TEST(DemImport, TiffNoDataIsFilledWithTheMinimumAndCounted) {
  const fs::path dir = temp_dir();
  std::vector<float> px(16 * 8, 100.0f);
  px[5] = -9999.0f;
  px[17] = -9999.0f;
  px[40] = 20.0f;
  write_bytes(dir / "nd.tif", make_geotiff(16, 8, px, "-9999", 30.0));
  auto dem = read_dem_file((dir / "nd.tif").string());
  ASSERT_TRUE(dem.ok()) << dem.error().describe();
  EXPECT_EQ(dem->nodata_count, 2);
  EXPECT_EQ(dem->scale_source, "geotiff");
  EXPECT_DOUBLE_EQ(dem->meters_per_sample, 30.0);
  auto w = import_dem(*dem);
  ASSERT_TRUE(w.ok());
  EXPECT_EQ(w->report.nodata_count, 2);
  EXPECT_NEAR(w->report.nodata_fill_m, 20.0, w->report.meters_per_unit);
  EXPECT_EQ(w->world.coarse(5, 0), w->world.coarse(8, 2)) << "NoData sample gets the fill (the minimum)";
  fs::remove_all(dir);
}

TEST(DemImport, TiffTagParserNeverReadsOutOfBoundsOnCorruptFiles) {
  std::vector<float> px(16 * 8, 1.0f);
  const auto good = make_geotiff(16, 8, px, "-9999", 2.0);
  std::mt19937 rng(5);
  for (int round = 0; round < 3000; ++round) {
    auto bad = good;
    const int flips = 1 + int(rng() % 4);
    for (int i = 0; i < flips; ++i) bad[rng() % 200] = uint8_t(rng());
    if (round % 7 == 0) bad.resize(rng() % bad.size());
    (void)read_tiff_geo_tags(bad);  // must return, never crash (ASan checks the reads)
  }
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
