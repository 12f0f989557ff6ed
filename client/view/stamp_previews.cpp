#include "client/view/stamp_previews.h"

#include <epoxy/gl.h>

#include <algorithm>

namespace loam::view {

PreviewImage preview_rgba(const StampTexture& image, int32_t side) {
  PreviewImage out;
  if (image.width <= 0 || image.height <= 0 || side <= 0) return out;
  const int32_t big = std::max(image.width, image.height);
  const int32_t step = std::max(1, (big + side - 1) / side);  // source pixels per preview pixel
  out.width = std::max(1, image.width / step);
  out.height = std::max(1, image.height / step);
  std::vector<double> mean(size_t(out.width) * size_t(out.height));
  for (int32_t y = 0; y < out.height; ++y) {
    for (int32_t x = 0; x < out.width; ++x) {
      double sum = 0;
      int32_t n = 0;
      for (int32_t sy = y * step; sy < std::min((y + 1) * step, image.height); ++sy) {
        for (int32_t sx = x * step; sx < std::min((x + 1) * step, image.width); ++sx, ++n)
          sum += image.samples[size_t(sy) * size_t(image.width) + size_t(sx)];
      }
      mean[size_t(y) * size_t(out.width) + size_t(x)] = n ? sum / n : 0.0;
    }
  }
  const auto [lo, hi] = std::minmax_element(mean.begin(), mean.end());
  const double range = *hi - *lo;
  out.rgba.resize(mean.size() * 4);
  for (size_t i = 0; i < mean.size(); ++i) {
    const uint8_t v =
        range > 0 ? uint8_t(std::clamp((mean[i] - *lo) / range * 255.0 + 0.5, 0.0, 255.0)) : 128;
    out.rgba[4 * i] = out.rgba[4 * i + 1] = out.rgba[4 * i + 2] = v;
    out.rgba[4 * i + 3] = 255;
  }
  return out;
}

void StampPreviews::update(const TextureRegistry& textures) {
  if (textures.size() == previews_.size()) return;
  for (const StampTexture* t : textures.all()) {
    if (previews_.count(t->id)) continue;
    const PreviewImage img = preview_rgba(*t, side_);
    StampPreview p;
    p.id = t->id;
    p.width = t->width;
    p.height = t->height;
    p.texture = gpu::make_texture(GL_TEXTURE_2D);
    glTextureStorage2D(p.texture.get(), 1, GL_RGBA8, img.width, img.height);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTextureSubImage2D(p.texture.get(), 0, 0, 0, img.width, img.height, GL_RGBA, GL_UNSIGNED_BYTE,
                        img.rgba.data());
    glTextureParameteri(p.texture.get(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(p.texture.get(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    previews_.emplace(t->id, std::move(p));
  }
}

const StampPreview* StampPreviews::find(uint64_t id) const {
  const auto it = previews_.find(id);
  return it == previews_.end() ? nullptr : &it->second;
}

}  // namespace loam::view
