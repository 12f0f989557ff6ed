// Uploads into toroidal textures: a level region of a clipmap keeps sample (x, y) at texel
// (x mod torus, y mod torus), so a rect of samples splits into at most four texel rects. Shared
// by the clipmap renderers (clipmap_renderer.h, error_clipmap_renderer.h).
#pragma once

#include <epoxy/gl.h>

#include <algorithm>
#include <cstdint>

#include "protocol/geometry.h"

namespace loam::render {

// Calls fn(piece, texel x, texel y) for the pieces a rect of a toroidal region splits into in
// its `torus`-sized texture (a rect no wider than the torus wraps at most once per axis: up
// to four pieces), with unpack alignment 1 set; returns the samples covered.
template <typename Fn>
int64_t for_each_torus_piece(const RectI& rect, int64_t torus, const Fn& fn) {
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  int64_t texels = 0;
  for (int64_t y = rect.y0; y < rect.y1;) {
    const int64_t ty = floor_mod(y, torus), h = std::min(rect.y1 - y, torus - ty);
    for (int64_t x = rect.x0; x < rect.x1;) {
      const int64_t tx = floor_mod(x, torus), w = std::min(rect.x1 - x, torus - tx);
      fn(RectI{x, y, x + w, y + h}, tx, ty);
      texels += w * h;
      x += w;
    }
    y += h;
  }
  return texels;
}

}  // namespace loam::render
