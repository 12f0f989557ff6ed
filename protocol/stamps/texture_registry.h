// Stamp textures: grayscale images referenced by the hash of their content.
//
// A texture stamp names its image by a 64-bit content id (XXH3-64 of the canonical bytes:
// width and height as little-endian uint32, then the samples as little-endian uint16, row 0
// first). Every party registers the same decoded samples and so derives the same id; the
// image itself travels once. This module is pure: it takes decoded 16-bit gray samples
// (decoding image files lives outside protocol/, see dem/stamp_texture_io.h).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <unordered_map>
#include <vector>

#include "protocol/result.h"

namespace loam {

inline constexpr int32_t kMaxTextureSide = 4096;  // keeps image coordinates within 32 bits

struct StampTexture {
  int32_t width = 0;
  int32_t height = 0;
  std::vector<uint16_t> samples;  // row-major, width * height, 0..65535 = 0..full intensity
  uint64_t id = 0;
};

// The content id of an image (see the header comment). Pure; any input.
uint64_t texture_content_id(int32_t width, int32_t height, std::span<const uint16_t> samples);

class TextureRegistry {
 public:
  // Registers an image and returns its content id; registering the same content again
  // returns the same id. Rejects empty images, sides above kMaxTextureSide and a sample
  // count that does not match width * height.
  Result<uint64_t> add(int32_t width, int32_t height, std::span<const uint16_t> samples);

  // The image with this id, or nullptr.
  const StampTexture* find(uint64_t id) const;
  bool contains(uint64_t id) const { return find(id) != nullptr; }
  // Every registered image, ordered by id (snapshots store them in this order).
  std::vector<const StampTexture*> all() const;
  size_t size() const { return textures_.size(); }

 private:
  std::unordered_map<uint64_t, std::shared_ptr<const StampTexture>> textures_;
};

}  // namespace loam
