#include "protocol/snapshot/stamp_image_file.h"

#include <xxhash.h>

#include <cstring>

#include "protocol/byte_order.h"

namespace loam {

namespace {

constexpr char kImageMagic[8] = {'L', 'O', 'A', 'M', 'I', 'M', 'G', '\n'};
constexpr size_t kFixedBytes = sizeof(kImageMagic) + 4 + 4;

}  // namespace

std::vector<uint8_t> encode_stamp_image(const StampTexture& t) {
  std::vector<uint8_t> out(kFixedBytes + t.samples.size() * 2 + 8);
  std::memcpy(out.data(), kImageMagic, sizeof kImageMagic);
  store_le<uint32_t>(out.data() + 8, uint32_t(t.width));
  store_le<uint32_t>(out.data() + 12, uint32_t(t.height));
  for (size_t i = 0; i < t.samples.size(); ++i)
    store_le<uint16_t>(out.data() + kFixedBytes + 2 * i, t.samples[i]);
  const size_t body = out.size() - 8;
  store_le<uint64_t>(out.data() + body, XXH3_64bits(out.data(), body));
  return out;
}

Result<StampTexture> decode_stamp_image(std::span<const uint8_t> bytes, const std::string& name) {
  if (bytes.size() < kFixedBytes + 8)
    return make_error(ErrorCode::kTruncated, name, "shorter than its header");
  if (std::memcmp(bytes.data(), kImageMagic, sizeof kImageMagic) != 0)
    return make_error(ErrorCode::kCorrupt, name, "not a Loam stamp image");
  const uint32_t w = load_le<uint32_t>(bytes.data() + 8);
  const uint32_t h = load_le<uint32_t>(bytes.data() + 12);
  if (w == 0 || h == 0 || w > uint32_t(kMaxTextureSide) || h > uint32_t(kMaxTextureSide))
    return make_error(ErrorCode::kCorrupt, name,
                      "size " + std::to_string(w) + "x" + std::to_string(h) + " out of range");
  const size_t expected = kFixedBytes + size_t(w) * size_t(h) * 2 + 8;
  if (bytes.size() != expected) {
    return make_error(ErrorCode::kTruncated, name,
                      std::to_string(bytes.size()) + " bytes, a " + std::to_string(w) + "x" +
                          std::to_string(h) + " image needs " + std::to_string(expected));
  }
  const size_t body = expected - 8;
  if (load_le<uint64_t>(bytes.data() + body) != XXH3_64bits(bytes.data(), body))
    return make_error(ErrorCode::kCorrupt, name, "checksum mismatch");
  StampTexture t;
  t.width = int32_t(w);
  t.height = int32_t(h);
  t.samples.resize(size_t(w) * size_t(h));
  for (size_t i = 0; i < t.samples.size(); ++i)
    t.samples[i] = load_le<uint16_t>(bytes.data() + kFixedBytes + 2 * i);
  t.id = texture_content_id(t.width, t.height, t.samples);
  return t;
}

uint64_t max_stamp_image_file_bytes() {
  return kFixedBytes + uint64_t(kMaxTextureSide) * kMaxTextureSide * 2 + 8;
}

}  // namespace loam
