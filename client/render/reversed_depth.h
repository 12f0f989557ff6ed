// The depth test every terrain renderer draws with (camera.h: reversed depth). A scope object,
// so that code sharing the context (the GPU stamper's passes) finds GL's default clip control
// again.
#pragma once

#include <epoxy/gl.h>

#include "client/scene/camera.h"

namespace loam::render {

// Clears and tests depth the reversed way for its lifetime: clip z 0..w, GL_GREATER.
class ReversedDepthTest {
 public:
  ReversedDepthTest() {
    glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_GREATER);
  }
  ~ReversedDepthTest() {
    glClipControl(GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE);
    glDepthFunc(GL_LESS);
  }
  ReversedDepthTest(const ReversedDepthTest&) = delete;
  ReversedDepthTest& operator=(const ReversedDepthTest&) = delete;
};

// What a depth buffer is cleared to before a reversed-depth frame: the far plane.
inline void clear_depth_reversed() {
  glDepthMask(GL_TRUE);
  glClearDepth(double(scene::kBackgroundDepth));
}

}  // namespace loam::render
