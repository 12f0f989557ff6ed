#include "protocol/stamps/texture_registry.h"

#include <xxhash.h>

#include <algorithm>
#include <string>

namespace loam {

uint64_t texture_content_id(int32_t width, int32_t height, std::span<const uint16_t> samples) {
  // Canonical little-endian bytes, so the id does not depend on the host's byte order.
  std::vector<uint8_t> bytes;
  bytes.reserve(8 + samples.size() * 2);
  for (const uint32_t v : {uint32_t(width), uint32_t(height)}) {
    for (int b = 0; b < 4; ++b) bytes.push_back(uint8_t(v >> (8 * b)));
  }
  for (const uint16_t s : samples) {
    bytes.push_back(uint8_t(s & 0xFF));
    bytes.push_back(uint8_t(s >> 8));
  }
  return XXH3_64bits(bytes.data(), bytes.size());
}

Result<uint64_t> TextureRegistry::add(int32_t width, int32_t height, std::span<const uint16_t> samples) {
  if (width <= 0 || height <= 0) {
    return make_error(ErrorCode::kInvalidArgument, "texture.size", "width and height must be positive");
  }
  if (width > kMaxTextureSide || height > kMaxTextureSide) {
    return make_error(ErrorCode::kOversize, "texture.size",
                      "sides are limited to " + std::to_string(kMaxTextureSide) + " samples");
  }
  if (samples.size() != size_t(width) * size_t(height)) {
    return make_error(ErrorCode::kInvalidArgument, "texture.samples",
                      "expected " + std::to_string(size_t(width) * size_t(height)) + " samples, got " +
                          std::to_string(samples.size()));
  }
  const uint64_t id = texture_content_id(width, height, samples);
  if (textures_.find(id) == textures_.end()) {
    auto t = std::make_shared<StampTexture>();
    t->width = width;
    t->height = height;
    t->samples.assign(samples.begin(), samples.end());
    t->id = id;
    textures_.emplace(id, std::move(t));
  }
  return id;
}

const StampTexture* TextureRegistry::find(uint64_t id) const {
  const auto it = textures_.find(id);
  return it == textures_.end() ? nullptr : it->second.get();
}

std::vector<const StampTexture*> TextureRegistry::all() const {
  std::vector<const StampTexture*> out;
  out.reserve(textures_.size());
  for (const auto& [id, t] : textures_) out.push_back(t.get());
  std::sort(out.begin(), out.end(),
            [](const StampTexture* a, const StampTexture* b) { return a->id < b->id; });
  return out;
}

}  // namespace loam
