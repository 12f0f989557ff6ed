// The one little-endian helper every file format and message goes through.
#include "protocol/byte_order.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <vector>

namespace loam {
namespace {

TEST(ByteOrder, StoreWritesTheLeastSignificantByteFirstForEveryWidth) {
  std::array<uint8_t, 8> b{};
  store_le<uint16_t>(b.data(), 0x0102u);
  EXPECT_EQ(b[0], 0x02);
  EXPECT_EQ(b[1], 0x01);
  store_le<uint32_t>(b.data(), 0x01020304u);
  EXPECT_EQ((std::array<uint8_t, 4>{b[0], b[1], b[2], b[3]}), (std::array<uint8_t, 4>{4, 3, 2, 1}));
  store_le<uint64_t>(b.data(), 0x0102030405060708ull);
  EXPECT_EQ(b, (std::array<uint8_t, 8>{8, 7, 6, 5, 4, 3, 2, 1}));
}

TEST(ByteOrder, SignedValuesRoundTripThroughTheirTwosComplementBytes) {
  std::array<uint8_t, 8> b{};
  store_le<int32_t>(b.data(), -2);
  EXPECT_EQ((std::array<uint8_t, 4>{b[0], b[1], b[2], b[3]}),
            (std::array<uint8_t, 4>{0xFE, 0xFF, 0xFF, 0xFF}));
  EXPECT_EQ(load_le<int32_t>(b.data()), -2);
  store_le<int64_t>(b.data(), INT64_MIN);
  EXPECT_EQ(load_le<int64_t>(b.data()), INT64_MIN);
  store_le<int8_t>(b.data(), int8_t(-128));
  EXPECT_EQ(load_le<int8_t>(b.data()), -128);
}

// The codec reads words at odd offsets inside a payload.
TEST(ByteOrder, LoadReadsFromUnalignedAddresses) {
  const std::array<uint8_t, 9> b{0xAA, 0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01};
  EXPECT_EQ(load_le<uint64_t>(b.data() + 1), 0x0102030405060708ull);
  EXPECT_EQ(load_le<uint16_t>(b.data() + 1), 0x0708u);
}

TEST(ByteOrder, AppendGrowsTheBufferByTheValueWidth) {
  std::vector<uint8_t> out{0x11};
  append_le<uint16_t>(out, 0xBEEFu);
  append_le<uint32_t>(out, 1u);
  EXPECT_EQ(out, (std::vector<uint8_t>{0x11, 0xEF, 0xBE, 1, 0, 0, 0}));
}

}  // namespace
}  // namespace loam
