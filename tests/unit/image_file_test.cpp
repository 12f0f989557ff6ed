// Image files without a general image library: what dem/image_file.h writes reads back
// sample for sample through the DEM readers (GDAL for PNG and TIFF, OpenEXR), the OpenEXR
// reader's channel order and its refusal of damaged or oversized files, and the stamp
// texture mapping of the PNG kinds only GDAL exposes raw (low-bit gray, palettes).
#include "dem/image_file.h"

#include <cpl_conv.h>
#include <gdal.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>
#include <string>
#include <vector>

#include "dem/exr_source.h"
#include "dem/gdal_errors.h"
#include "dem/gdal_source.h"
#include "dem/stamp_texture_io.h"

namespace loam {
namespace {

namespace fs = std::filesystem;

fs::path image_test_dir() {
  const fs::path dir = fs::temp_directory_path() / "loam_image_file_test";
  fs::create_directories(dir);
  return dir;
}

std::vector<uint8_t> image_file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// Every band of a file, read back through the DEM readers, interleaved like the writer's input.
std::vector<double> read_back(const fs::path& path, int32_t& width, int32_t& height, int32_t& channels,
                              std::vector<RasterBandInfo>* bands = nullptr) {
  const std::string ext = path.extension().string().substr(1);
  auto src = ext == "exr" ? open_exr_file(path.string()) : open_gdal_file(path.string(), ext);
  EXPECT_TRUE(src.ok()) << (src.ok() ? "" : src.error().describe());
  if (!src.ok()) return {};
  RasterSource& r = *src.value();
  width = int32_t(r.width());
  height = int32_t(r.height());
  channels = r.band_count();
  std::vector<double> out(size_t(width) * size_t(height) * size_t(channels));
  std::vector<double> band(size_t(width) * size_t(height));
  for (int c = 1; c <= channels; ++c) {
    if (bands) bands->push_back(r.band(c));
    EXPECT_TRUE(r.read_rows(c, 0, height, band).ok());
    for (size_t i = 0; i < band.size(); ++i) out[i * size_t(channels) + size_t(c - 1)] = band[i];
  }
  return out;
}

template <typename T>
void expect_image_round_trip(const std::string& file, int32_t w, int32_t h, int32_t channels,
                             const std::vector<T>& px) {
  SCOPED_TRACE(file);
  const fs::path path = image_test_dir() / file;
  const Status s = write_image_file(path.string(), image_view(w, h, channels, std::span<const T>(px)));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  EXPECT_FALSE(fs::exists(path.string() + ".aux.xml")) << "no sidecar beside the image";
  int32_t rw = 0, rh = 0, rc = 0;
  const std::vector<double> back = read_back(path, rw, rh, rc);
  EXPECT_EQ(rw, w);
  EXPECT_EQ(rh, h);
  ASSERT_EQ(rc, channels);
  ASSERT_EQ(back.size(), px.size());
  for (size_t i = 0; i < px.size(); ++i) ASSERT_EQ(back[i], double(px[i])) << "sample " << i;
}

TEST(ImageFile, PngTiffAndExrReadBackSampleForSampleInEveryChannelLayout) {
  for (int32_t channels = 1; channels <= 4; ++channels) {
    const int32_t w = 7, h = 5;  // odd sides: no row padding hides a stride error
    std::vector<uint8_t> p8(size_t(w * h * channels));
    std::vector<uint16_t> p16(p8.size());
    std::vector<float> pf(p8.size());
    for (size_t i = 0; i < p8.size(); ++i) {
      p8[i] = uint8_t(i * 37 + 11);
      p16[i] = uint16_t(i * 4099 + 3);
      pf[i] = float(i) * -0.37f + 1234.5f;
    }
    const std::string n = std::to_string(channels);
    expect_image_round_trip("c" + n + "_8.png", w, h, channels, p8);
    expect_image_round_trip("c" + n + "_16.png", w, h, channels, p16);
    expect_image_round_trip("c" + n + "_16.tif", w, h, channels, p16);
    expect_image_round_trip("c" + n + "_f.tif", w, h, channels, pf);
    expect_image_round_trip("c" + n + "_f.exr", w, h, channels, pf);
  }
}

TEST(ImageFile, WrongSizesFormatsAndPathsAreTypedErrorsNamingTheFile) {
  const std::vector<float> f(6, 1.0f);
  const std::vector<uint8_t> b(6, 1);
  const std::string dir = image_test_dir().string();
  struct Case {
    const char* file;
    ImageView image;
    ErrorCode code;
  };
  const std::vector<Case> cases = {
      {"f.png", image_view(3, 2, 1, std::span<const float>(f)), ErrorCode::kUnsupported},  // PNG is not float
      {"b.exr", image_view(3, 2, 1, std::span<const uint8_t>(b)), ErrorCode::kUnsupported},  // EXR is float
      {"b.bmp", image_view(3, 2, 1, std::span<const uint8_t>(b)), ErrorCode::kUnsupported},
      {"short.png", image_view(4, 2, 1, std::span<const uint8_t>(b)), ErrorCode::kInvalidArgument},
      {"no/such/dir/x.png", image_view(3, 2, 1, std::span<const uint8_t>(b)), ErrorCode::kIo},
      {"no/such/dir/x.exr", image_view(3, 2, 1, std::span<const float>(f)), ErrorCode::kIo},
  };
  for (const Case& c : cases) {
    const std::string path = dir + "/" + c.file;
    const Status s = write_image_file(path, c.image);
    ASSERT_FALSE(s.ok()) << path;
    EXPECT_EQ(s.error().code, c.code) << s.error().describe();
    EXPECT_EQ(s.error().field, path);
  }
}

TEST(ExrSource, ChannelsComeInColourOrderWithTheirTypesAndNoGeoreference) {
  const fs::path path = image_test_dir() / "rgba.exr";
  std::vector<float> px = {1, 2, 3, 4, 5, 6, 7, 8};  // two RGBA pixels
  ASSERT_TRUE(write_image_file(path.string(), image_view(2, 1, 4, std::span<const float>(px))).ok());
  int32_t w = 0, h = 0, c = 0;
  std::vector<RasterBandInfo> bands;
  EXPECT_EQ(read_back(path, w, h, c, &bands), std::vector<double>(px.begin(), px.end()));
  ASSERT_EQ(bands.size(), 4u);
  EXPECT_EQ(bands[0].color, "Red");
  EXPECT_EQ(bands[1].color, "Green");
  EXPECT_EQ(bands[2].color, "Blue");
  EXPECT_EQ(bands[3].color, "Alpha");
  EXPECT_EQ(bands[0].sample_type, "float32");
  auto src = open_exr_file(path.string());
  ASSERT_TRUE(src.ok());
  EXPECT_EQ(src.value()->format(), "OpenEXR");
  EXPECT_FALSE(src.value()->georef().has_transform);
}

// Damaged files: cut anywhere, or a header claiming a side of a billion samples, is an Error
// (never a crash, never an allocation sized by the claim).
TEST(ExrSource, TruncatedFilesAndGiantDataWindowsAreRefusedAsCorrupt) {
  const fs::path path = image_test_dir() / "whole.exr";
  std::vector<float> px(64 * 16);
  for (size_t i = 0; i < px.size(); ++i) px[i] = float(i);
  ASSERT_TRUE(write_image_file(path.string(), image_view(64, 16, 1, std::span<const float>(px))).ok());
  const std::vector<uint8_t> bytes = image_file_bytes(path);
  ASSERT_GT(bytes.size(), 100u);
  std::vector<double> rows(64 * 16);
  for (size_t cut = 0; cut < bytes.size(); cut += std::max<size_t>(1, bytes.size() / 97)) {
    const std::span<const uint8_t> part(bytes.data(), cut);
    auto src = open_exr_memory(part, "cut.exr");
    if (!src.ok()) {
      EXPECT_EQ(src.error().code, ErrorCode::kCorrupt) << "cut at " << cut;
      EXPECT_EQ(src.error().field, "cut.exr");
      continue;
    }
    const Status s = src.value()->read_rows(1, 0, 16, rows);
    EXPECT_FALSE(s.ok()) << "a file cut at " << cut << " of " << bytes.size() << " bytes read whole";
    if (!s.ok()) {
      EXPECT_EQ(s.error().code, ErrorCode::kCorrupt);
    }
  }
  // dataWindow is a box2i attribute: name, type, size (16), then xMin, yMin, xMax, yMax.
  std::vector<uint8_t> giant = bytes;
  const std::string key = std::string("dataWindow") + '\0' + "box2i" + '\0';
  auto at = std::search(giant.begin(), giant.end(), key.begin(), key.end());
  ASSERT_NE(at, giant.end());
  const size_t y_max = size_t(at - giant.begin()) + key.size() + 4 + 12;
  const int32_t huge = 1 << 30;
  std::memcpy(giant.data() + y_max, &huge, sizeof huge);
  auto src = open_exr_memory(giant, "giant.exr");
  ASSERT_FALSE(src.ok());
  EXPECT_EQ(src.error().code, ErrorCode::kCorrupt) << src.error().describe();
}

// Low-bit gray and palette PNGs, written through GDAL's PNG driver.
fs::path write_gdal_png(const std::string& file, int w, int h, const std::vector<uint8_t>& px,
                        const char* nbits, bool palette) {
  ensure_gdal_ready();
  const fs::path path = image_test_dir() / file;
  GDALDatasetH mem = GDALCreate(GDALGetDriverByName("MEM"), "", w, h, 1, GDT_Byte, nullptr);
  EXPECT_TRUE(mem);
  GDALRasterBandH band = GDALGetRasterBand(mem, 1);
  EXPECT_EQ(GDALRasterIO(band, GF_Write, 0, 0, w, h, const_cast<uint8_t*>(px.data()), w, h, GDT_Byte, 0, 0),
            CE_None);
  if (palette) {
    GDALColorTableH ct = GDALCreateColorTable(GPI_RGB);
    for (int i = 0; i < 4; ++i) {
      const GDALColorEntry e = {short(i * 60), short(255 - i * 60), 7, 255};
      GDALSetColorEntry(ct, i, &e);
    }
    GDALSetRasterColorTable(band, ct);
    GDALDestroyColorTable(ct);
  }
  std::string opt = nbits ? std::string("NBITS=") + nbits : "";
  const char* options[] = {nbits ? opt.c_str() : nullptr, nullptr};
  GDALDatasetH png = GDALCreateCopy(GDALGetDriverByName("PNG"), path.string().c_str(), mem, FALSE,
                                    const_cast<char**>(options), nullptr, nullptr);
  EXPECT_TRUE(png);
  if (png) GDALClose(png);
  GDALClose(mem);
  return path;
}

TEST(StampTextureIo, OneTwoAndFourBitGrayWidenToEightBitsAsPngDefines) {
  struct Case {
    const char* nbits;
    std::vector<uint8_t> stored;
    std::vector<uint16_t> want;  // 8-bit widened (1 -> 255, 2-bit 1 -> 85, 4-bit 1 -> 17), times 257
  };
  const std::vector<Case> cases = {
      {"1", {0, 1, 1, 0}, {0, 65535, 65535, 0}},
      {"2", {0, 1, 2, 3}, {0, 85 * 257, 170 * 257, 65535}},
      {"4", {0, 1, 9, 15}, {0, 17 * 257, 153 * 257, 65535}},
  };
  for (const Case& c : cases) {
    const fs::path path =
        write_gdal_png(std::string("gray") + c.nbits + ".png", 4, 1, c.stored, c.nbits, false);
    auto t = read_stamp_texture_file(path.string());
    ASSERT_TRUE(t.ok()) << t.error().describe();
    EXPECT_EQ(t.value().samples, c.want) << c.nbits << "-bit";
  }
}

TEST(StampTextureIo, PaletteImagesAreRefusedAsColour) {
  const fs::path path = write_gdal_png("palette.png", 2, 2, {0, 1, 2, 3}, nullptr, true);
  auto t = read_stamp_texture_file(path.string());
  ASSERT_FALSE(t.ok());
  EXPECT_EQ(t.error().code, ErrorCode::kUnsupported);
  EXPECT_EQ(t.error().field, path.string());
}

}  // namespace
}  // namespace loam
