// Previews of the server's registered stamp images for the tool panel: each image downscaled
// (box filter) to a small gray RGBA texture, made once when the image arrives.
// preview_rgba() is pure; StampPreviews holds the GL textures (the context current).
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <vector>

#include "gpu/gl_handle.h"
#include "protocol/stamps/texture_registry.h"

namespace loam::view {

struct PreviewImage {
  int32_t width = 0, height = 0;
  std::vector<uint8_t> rgba;  // row-major, top row first
};

// The image scaled to fit `side` x `side` (never up), its range stretched to 0..255 so a
// faint image still shows its shape; a flat image is mid gray.
PreviewImage preview_rgba(const StampTexture& image, int32_t side);

struct StampPreview {
  uint64_t id = 0;
  int32_t width = 0, height = 0;  // of the registered image
  gpu::GlTexture texture;         // RGBA8 preview
};

class StampPreviews {
 public:
  explicit StampPreviews(int32_t side = 64) : side_(side) {}
  // Makes the previews of registered images that have none yet.
  void update(const TextureRegistry& textures);
  const StampPreview* find(uint64_t id) const;

 private:
  int32_t side_;
  std::map<uint64_t, StampPreview> previews_;
};

}  // namespace loam::view
