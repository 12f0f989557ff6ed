// Stored texture-stamp images: round trip, and every damaged or hostile file is an Error
// naming it, never an allocation the file does not justify.
#include "protocol/snapshot/stamp_image_file.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "protocol/byte_order.h"

namespace loam {
namespace {

StampTexture sample_image(int32_t w, int32_t h) {
  StampTexture t;
  t.width = w;
  t.height = h;
  for (int32_t i = 0; i < w * h; ++i) t.samples.push_back(uint16_t(i * 2654435761u >> 16));
  t.id = texture_content_id(w, h, t.samples);
  return t;
}

TEST(StampImageFile, EncodedImageDecodesToTheSameSamplesAndId) {
  const StampTexture t = sample_image(17, 5);
  const std::vector<uint8_t> bytes = encode_stamp_image(t);
  auto back = decode_stamp_image(bytes, "a.loamimg");
  ASSERT_TRUE(back.ok()) << back.error().describe();
  EXPECT_EQ(back->samples, t.samples);
  EXPECT_EQ(back->id, t.id);
  if (std::getenv("LOAM_UPDATE_GOLDEN")) {  // the fuzzer's seed corpus
    const auto dir = std::filesystem::path(LOAM_SOURCE_DIR) / "fuzz/corpus/stamp_image_fuzz";
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "seed-valid", std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  }
}

TEST(StampImageFile, EveryPrefixAndEveryFlippedByteIsAnErrorNamingTheFile) {
  const std::vector<uint8_t> bytes = encode_stamp_image(sample_image(6, 4));
  for (size_t n = 0; n < bytes.size(); ++n) {
    // Its own allocation, so ASan sees any read past the end.
    const std::vector<uint8_t> prefix(bytes.begin(), bytes.begin() + ptrdiff_t(n));
    auto r = decode_stamp_image(prefix, "p.loamimg");
    ASSERT_FALSE(r.ok()) << n;
    EXPECT_EQ(r.error().field, "p.loamimg");
  }
  for (size_t i = 0; i < bytes.size(); ++i) {
    std::vector<uint8_t> b = bytes;
    b[i] ^= 0x20;
    EXPECT_FALSE(decode_stamp_image(b, "f.loamimg").ok()) << i;
  }
}

TEST(StampImageFile, HeaderClaimingAHugeImageIsRefusedBeforeAllocating) {
  std::vector<uint8_t> bytes = encode_stamp_image(sample_image(2, 2));
  store_le<uint32_t>(bytes.data() + 8, 4096);
  store_le<uint32_t>(bytes.data() + 12, 4096);  // 32 MiB claimed by a 32-byte file
  auto r = decode_stamp_image(bytes, "huge.loamimg");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kTruncated);
  store_le<uint32_t>(bytes.data() + 8, 5000);
  EXPECT_EQ(decode_stamp_image(bytes, "huge.loamimg").error().code, ErrorCode::kCorrupt);
}

}  // namespace
}  // namespace loam
