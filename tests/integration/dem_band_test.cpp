// `serve --dem FILE --dem-band N --nodata-fill F`: the band and the NoData fill are recorded in
// the log's import parameters, so recovery and `replay` read the same band of a multi-band image
// and fill its NoData the same way; a multi-band image without a named band is refused at start;
// logs written before the fill was a choice replay with the minimum fill they were made with.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <vector>

#include "server/replay.h"
#include "server/storage.h"

namespace loam::test {
namespace {

namespace fs = std::filesystem;

// An uncompressed 8-bit RGB TIFF (one strip) whose three channels are different ramps.
void write_rgb_tiff(const fs::path& path, uint32_t w, uint32_t h) {
  std::vector<uint8_t> b;
  auto u16 = [&](uint16_t v) {
    b.push_back(uint8_t(v));
    b.push_back(uint8_t(v >> 8));
  };
  auto u32 = [&](uint32_t v) {
    for (int i = 0; i < 4; ++i) b.push_back(uint8_t(v >> (8 * i)));
  };
  const uint16_t ntags = 10;
  const uint32_t bits_at = 8 + 2 + ntags * 12 + 4, data_at = bits_at + 6;
  b.push_back('I');  // little-endian (two pushes: GCC 12 -O3 misreads an insert into the empty vector)
  b.push_back('I');
  u16(42);
  u32(8);
  u16(ntags);
  auto tag = [&](uint16_t t, uint16_t type, uint32_t count, uint32_t value) {
    u16(t);
    u16(type);
    u32(count);
    u32(value);
  };
  tag(256, 4, 1, w);
  tag(257, 4, 1, h);
  tag(258, 3, 3, bits_at);  // 8, 8, 8
  tag(259, 3, 1, 1);
  tag(262, 3, 1, 2);  // RGB
  tag(273, 4, 1, data_at);
  tag(277, 3, 1, 3);
  tag(278, 4, 1, h);
  tag(279, 4, 1, w * h * 3);
  tag(284, 3, 1, 1);  // chunky
  u32(0);
  for (int i = 0; i < 3; ++i) u16(8);
  for (uint32_t y = 0; y < h; ++y) {
    for (uint32_t x = 0; x < w; ++x) {
      b.push_back(uint8_t(x * 3));
      b.push_back(uint8_t(y * 5 + x));
      b.push_back(uint8_t(200 - y));
    }
  }
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

TEST(DemBand, ServeDemBandIsRecordedSoReplayReadsTheSameBand) {
  const fs::path dir = fs::temp_directory_path() / ("loam_dem_band_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  write_rgb_tiff(dir / "rgb.tif", 40, 30);
  const std::string dem = (dir / "rgb.tif").string();

  auto refused = server::open_storage((dir / "none").string(), dem, {});
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().describe().find("--band"), std::string::npos) << refused.error().describe();

  uint64_t green = 0, blue = 0;
  {
    auto opened = server::open_storage((dir / "green").string(), dem, {}, {}, {.band = 2, .nodata_fill = {}});
    ASSERT_TRUE(opened.ok()) << opened.error().describe();
    green = opened->terrain.world().world_hash();
    auto other = server::open_storage((dir / "blue").string(), dem, {}, {}, {.band = 3, .nodata_fill = {}});
    ASSERT_TRUE(other.ok()) << other.error().describe();
    blue = other->terrain.world().world_hash();
  }
  EXPECT_NE(green, blue);
  auto replayed =
      server::replay_log(server::list_segments((dir / "green").string()), (dir / "green").string());
  ASSERT_TRUE(replayed.ok()) << replayed.error().describe();
  EXPECT_EQ(replayed->world.world_hash(), green) << "replay must read band 2 again";
  fs::remove_all(dir);
}

// An ESRI ASCII grid with a hole of NoData in a slope.
void write_holed_grid(const fs::path& path) {
  std::ofstream f(path);
  f << "ncols 40\nnrows 30\nxllcorner 0\nyllcorner 0\ncellsize 10\nNODATA_value -9999\n";
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x < 40; ++x) {
      const bool hole = (x - 20) * (x - 20) + (y - 15) * (y - 15) <= 36;
      f << (hole ? -9999.0 : 100.0 + 2.0 * x + y) << (x + 1 < 40 ? " " : "\n");
    }
  }
}

TEST(DemBand, NodataFillIsRecordedSoReplayFillsTheSameWay) {
  const fs::path dir = fs::temp_directory_path() / ("loam_dem_fill_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  write_holed_grid(dir / "hole.asc");
  const std::string dem = (dir / "hole.asc").string();
  std::vector<uint64_t> hashes;
  for (const char* fill : {"interpolate", "min", "value:90"}) {
    const std::string data = (dir / fill).string();
    {
      auto opened =
          server::open_storage(data, dem, {}, {}, {.band = 0, .nodata_fill = *NodataFill::parse(fill)});
      ASSERT_TRUE(opened.ok()) << opened.error().describe();
      hashes.push_back(opened->terrain.world().world_hash());
    }
    auto replayed = server::replay_log(server::list_segments(data), data);
    ASSERT_TRUE(replayed.ok()) << replayed.error().describe();
    EXPECT_EQ(replayed->world.world_hash(), hashes.back()) << "replay must fill with " << fill << " again";
  }
  EXPECT_NE(hashes[0], hashes[1]);
  EXPECT_NE(hashes[1], hashes[2]);
  EXPECT_NE(hashes[0], hashes[2]);
  fs::remove_all(dir);
}

TEST(DemBand, ImportParametersOfOldAndNewLogsReadBack) {
  using server::DemChoice;
  const NodataFill min{NodataFill::Mode::kMin, 0};
  auto legacy = server::parse_dem_import_params("default import options");
  ASSERT_TRUE(legacy.ok());
  EXPECT_EQ(legacy->band, 0);
  EXPECT_EQ(legacy->nodata_fill, min) << "logs before the choice filled with the minimum";
  auto legacy_band = server::parse_dem_import_params("default import options, band 2");
  ASSERT_TRUE(legacy_band.ok());
  EXPECT_EQ(legacy_band->band, 2);
  EXPECT_EQ(legacy_band->nodata_fill, min);
  for (const DemChoice& c :
       {DemChoice{}, DemChoice{3, min}, DemChoice{0, {NodataFill::Mode::kValue, -1.5}},
        DemChoice{2, min, LocalProjection::kUtm}, DemChoice{0, {}, LocalProjection::kAzimuthalEquidistant}}) {
    const std::string text = server::dem_import_params(c);
    auto back = server::parse_dem_import_params(text);
    ASSERT_TRUE(back.ok()) << text;
    EXPECT_EQ(back->band, c.band) << text;
    EXPECT_EQ(back->nodata_fill, c.nodata_fill) << text;
    EXPECT_EQ(back->project, c.project) << text;
  }
  EXPECT_EQ(server::dem_import_params({}), "dem import: nodata interpolate");
  EXPECT_EQ(server::dem_import_params({2, {NodataFill::Mode::kValue, 7}, LocalProjection::kNone}),
            "dem import: band 2, nodata value:7");
  EXPECT_EQ(server::dem_import_params({2, min, LocalProjection::kUtm}),
            "dem import: band 2, project utm, nodata min");
  for (const char* bad :
       {"", "default import options, band 0", "default import options, band x", "dem import: nodata",
        "dem import: band 2 nodata min", "dem import: band 99999, nodata min", "dem import: nodata mean",
        "dem import: nodata min, band 2", "dem import: project none, nodata min",
        "dem import: project lcc, nodata min", "dem import: nodata min, project utm"}) {
    auto r = server::parse_dem_import_params(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error().code, ErrorCode::kUnsupported);
  }
}

}  // namespace
}  // namespace loam::test
