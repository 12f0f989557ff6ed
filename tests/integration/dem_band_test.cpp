// `serve --dem FILE --dem-band N`: the band is recorded in the log's import parameters, so
// recovery and `replay` read the same band of a multi-band image, and a multi-band image
// without a named band is refused at start.
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
    auto opened = server::open_storage((dir / "green").string(), dem, {}, {}, 2);
    ASSERT_TRUE(opened.ok()) << opened.error().describe();
    green = opened->terrain.world().world_hash();
    auto other = server::open_storage((dir / "blue").string(), dem, {}, {}, 3);
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

}  // namespace
}  // namespace loam::test
