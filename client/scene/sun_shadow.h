// The sun's shadow map frame: an orthographic view along the sun's direction over a square of
// the terrain around (and ahead of) the camera, in the renderer's camera-relative render frame
// (x east, y north, z up, the camera at the origin), with reversed depth (1 nearest the sun).
// The square is snapped to whole shadow-map texels in world space, so moving the camera slides
// the map by whole texels and shadow edges do not shimmer.
// Pure: no GL.
#pragma once

#include <cstdint>
#include <glm/glm.hpp>

#include "client/scene/camera.h"

namespace loam::scene {

struct SunShadowFrame {
  glm::mat4 light_view_proj{1.0f};  // render frame -> shadow clip space (x, y in [-1, 1], z in [0, 1])
  double half_extent_m = 0;         // of the square, in meters
  double texel_m = 0;               // shadow-map texel size, meters
};

// `to_sun`: unit vector toward the sun in the render frame. The square's half side is
// `radius_m`, over heights `min_z`..`max_z` (world meters); `texels` per side.
SunShadowFrame sun_shadow_frame(const Camera& camera, const glm::dvec3& to_sun, double radius_m, double min_z,
                                double max_z, int32_t texels);

}  // namespace loam::scene
