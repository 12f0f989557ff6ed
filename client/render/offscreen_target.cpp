#include "client/render/offscreen_target.h"

#include <cstdio>
#include <span>

#include "client/render/reversed_depth.h"
#include "dem/image_file.h"

namespace loam::render {

Result<OffscreenTarget> OffscreenTarget::create(int32_t width, int32_t height) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384) {
    return make_error(ErrorCode::kInvalidArgument, "render.size", "must be 1..16384 each way");
  }
  OffscreenTarget t;
  t.width_ = width;
  t.height_ = height;
  t.color_ = gpu::make_texture(GL_TEXTURE_2D);
  glTextureStorage2D(t.color_.get(), 1, GL_RGBA8, width, height);
  t.depth_ = gpu::make_texture(GL_TEXTURE_2D);
  glTextureStorage2D(t.depth_.get(), 1, GL_DEPTH_COMPONENT32F, width, height);
  GLuint fbo = 0;
  glCreateFramebuffers(1, &fbo);
  t.fbo_ = gpu::GlFramebuffer(fbo);
  glNamedFramebufferTexture(fbo, GL_COLOR_ATTACHMENT0, t.color_.get(), 0);
  glNamedFramebufferTexture(fbo, GL_DEPTH_ATTACHMENT, t.depth_.get(), 0);
  if (glCheckNamedFramebufferStatus(fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    return make_error(ErrorCode::kUnsupported, "render.framebuffer",
                      "RGBA8 + depth32F framebuffer incomplete");
  }
  return t;
}

void OffscreenTarget::begin(float r, float g, float b, float a) const {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_.get());
  glViewport(0, 0, width_, height_);
  glClearColor(r, g, b, a);
  clear_depth_reversed();
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
}

std::vector<uint8_t> OffscreenTarget::read_rgba() const {
  const size_t row = size_t(width_) * 4;
  std::vector<uint8_t> gl(row * size_t(height_)), out(gl.size());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glGetTextureImage(color_.get(), 0, GL_RGBA, GL_UNSIGNED_BYTE, GLsizei(gl.size()), gl.data());
  // GL's row 0 is the bottom: flip so row 0 is the top, as images are stored.
  for (int32_t y = 0; y < height_; ++y) {
    std::copy_n(gl.begin() + ptrdiff_t(size_t(height_ - 1 - y) * row), row,
                out.begin() + ptrdiff_t(size_t(y) * row));
  }
  return out;
}

std::vector<float> OffscreenTarget::read_depth() const {
  const size_t w = size_t(width_);
  std::vector<float> gl(w * size_t(height_)), out(gl.size());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glGetTextureImage(depth_.get(), 0, GL_DEPTH_COMPONENT, GL_FLOAT, GLsizei(gl.size() * sizeof(float)),
                    gl.data());
  for (int32_t y = 0; y < height_; ++y) {
    std::copy_n(gl.begin() + ptrdiff_t(size_t(height_ - 1 - y) * w), w,
                out.begin() + ptrdiff_t(size_t(y) * w));
  }
  return out;
}

Status write_png(const std::string& path, int32_t width, int32_t height, const std::vector<uint8_t>& rgba,
                 bool keep_alpha) {
  const int channels = keep_alpha ? 4 : 3;
  std::vector<uint8_t> pixels;
  if (keep_alpha) {
    pixels = rgba;
  } else {
    pixels.reserve(size_t(width) * size_t(height) * 3);
    for (size_t i = 0; i < rgba.size(); i += 4)
      pixels.insert(pixels.end(), {rgba[i], rgba[i + 1], rgba[i + 2]});
  }
  return write_image_file(path, image_view(width, height, channels, std::span<const uint8_t>(pixels)));
}

}  // namespace loam::render
