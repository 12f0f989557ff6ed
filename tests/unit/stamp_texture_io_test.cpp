// Stamp textures read from image files: the 8-bit, 16-bit and float mappings to 16-bit
// samples, registration by content, and typed errors that name the file.
#include "dem/stamp_texture_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <vector>

#include "dem/image_file.h"

namespace loam {
namespace {

std::string temp_path(const std::string& file) {
  const auto dir = std::filesystem::temp_directory_path() / "loam_stamp_texture_io_test";
  std::filesystem::create_directories(dir);
  return (dir / file).string();
}

// Written by Loam's own image writer (dem/image_file.h): GDAL for PNG and TIFF, OpenEXR.
template <typename T>
void write_image(const std::string& path, int w, int h, int channels, const std::vector<T>& px) {
  const Status s = write_image_file(path, image_view(w, h, channels, std::span<const T>(px)));
  ASSERT_TRUE(s.ok()) << s.error().describe();
}

TEST(StampTextureIo, EightBitPngIsScaledBy257SoWhiteIsFullIntensity) {
  const std::string path = temp_path("gray8.png");
  write_image<uint8_t>(path, 3, 2, 1, {0, 1, 128, 200, 254, 255});
  auto t = read_stamp_texture_file(path);
  ASSERT_TRUE(t.ok()) << t.error().describe();
  EXPECT_EQ(t.value().width, 3);
  EXPECT_EQ(t.value().height, 2);
  EXPECT_EQ(t.value().samples, (std::vector<uint16_t>{0, 257, 32896, 51400, 65278, 65535}));
}

TEST(StampTextureIo, SixteenBitPngAndTiffKeepTheirSamplesAndRowOrder) {
  const std::vector<uint16_t> px = {0, 1, 65535, 12345, 40000, 7};
  for (const char* file : {"gray16.png", "gray16.tif"}) {
    const std::string path = temp_path(file);
    write_image(path, 2, 3, 1, px);
    auto t = read_stamp_texture_file(path);
    ASSERT_TRUE(t.ok()) << t.error().describe();
    EXPECT_EQ(t.value().width, 2) << file;
    EXPECT_EQ(t.value().samples, px) << file;
  }
}

TEST(StampTextureIo, FloatExrIsClampedToZeroOneScaledAndRoundedHalvesUp) {
  const std::string path = temp_path("grayf.exr");
  // 0.5 * 65535 = 32767.5 rounds up; out-of-range values clamp.
  write_image<float>(path, 4, 1, 1, {-0.25f, 0.5f, 1.0f, 7.0f});
  auto t = read_stamp_texture_file(path);
  ASSERT_TRUE(t.ok()) << t.error().describe();
  EXPECT_EQ(t.value().samples, (std::vector<uint16_t>{0, 32768, 65535, 65535}));
}

TEST(StampTextureIo, GrayWithAlphaUsesTheGrayChannelOnly) {
  const std::string path = temp_path("gray_alpha.png");
  write_image<uint8_t>(path, 2, 1, 2, {10, 0, 20, 255});
  auto t = read_stamp_texture_file(path);
  ASSERT_TRUE(t.ok()) << t.error().describe();
  EXPECT_EQ(t.value().samples, (std::vector<uint16_t>{2570, 5140}));
}

TEST(StampTextureIo, RegisteringTheSameImageFromTwoFormatsGivesOneContentId) {
  const std::vector<uint16_t> px = {0, 1000, 65535, 4};
  const std::string png = temp_path("same.png"), tif = temp_path("same.tif");
  write_image(png, 2, 2, 1, px);
  write_image(tif, 2, 2, 1, px);
  TextureRegistry reg;
  auto a = register_stamp_texture_file(reg, png);
  auto b = register_stamp_texture_file(reg, tif);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a.value(), b.value());
  EXPECT_EQ(a.value(), texture_content_id(2, 2, px));
  EXPECT_EQ(reg.size(), 1u);
}

TEST(StampTextureIo, EveryFailureIsTypedAndNamesTheFile) {
  const std::string missing = temp_path("does_not_exist.png");
  auto r = read_stamp_texture_file(missing);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kNotFound);
  EXPECT_EQ(r.error().field, missing);

  const std::string rgb = temp_path("rgb.png");
  write_image<uint8_t>(rgb, 1, 1, 3, {1, 2, 3});
  r = read_stamp_texture_file(rgb);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kUnsupported);
  EXPECT_EQ(r.error().field, rgb);

  const std::string junk = temp_path("junk.png");
  std::ofstream(junk, std::ios::binary) << "not a png at all";
  r = read_stamp_texture_file(junk);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kCorrupt);
  EXPECT_EQ(r.error().field, junk);

  const std::string nan = temp_path("nan.exr");
  write_image<float>(nan, 1, 1, 1, {std::nanf("")});
  r = read_stamp_texture_file(nan);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kNotFinite);
  EXPECT_EQ(r.error().field, nan);

  const std::vector<uint8_t> bytes = {1, 2, 3};
  r = read_stamp_texture_memory(bytes, "texture.bmp");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kUnsupported);
  EXPECT_EQ(r.error().field, "texture.bmp");

  const std::string big = temp_path("big.png");
  write_image(big, kMaxTextureSide + 1, 1, 1, std::vector<uint8_t>(size_t(kMaxTextureSide + 1)));
  r = read_stamp_texture_file(big);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kOversize);
}

}  // namespace
}  // namespace loam
