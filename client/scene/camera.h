// The renderer's camera and its projection, without GL: a position, a view direction and a
// lens in world meters, the view-projection matrix in the render frame (camera at the origin,
// x east, y north = world -y, z up, so nothing large reaches float) and picking (the world
// point under a pixel, from its depth). World frame: x east (+gx), y along +gy, z up.
#pragma once

#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <optional>
#include <string>

namespace loam::scene {

struct Camera {
  double x = 0, y = 0, z = 100;    // world meters
  double fx = 1, fy = 0, fz = 0;   // forward (world frame; need not be unit)
  double ux = 0, uy = 0, uz = 1;   // up hint
  double fov_y_degrees = 60.0;     // perspective
  double ortho_half_height = 0.0;  // > 0: orthographic, this many meters up from centre
  double near_m = 0.5, far_m = 20000.0;
  // Where the clipmap is centred, when not under the camera (tests that hold the view still
  // while the levels move); world meters.
  std::optional<std::array<double, 2>> lod_center;
};

// The camera from a position and a look-at point (world meters).
Camera look_at(double x, double y, double z, double tx, double ty, double tz);

// Why look_at(x, y, z, tx, ty, tz) has no view matrix, or nullopt when it has one: a
// coordinate that is not finite, a camera (within 1 mm of) its look point, or a view straight
// up or down (parallel to the up vector, which leaves the sideways axis undefined).
std::optional<std::string> look_at_problem(double x, double y, double z, double tx, double ty, double tz);

// Depth is reversed: clip z runs 0..w (glClipControl's GL_ZERO_TO_ONE), window depth is 1 at
// the near plane and 0 at the far plane and for the background (cleared to 0, tested with
// GL_GREATER; client/render/reversed_depth.h). With a float depth buffer that resolves every
// distance to about 2^-24 of itself; the conventional mapping resolves distance d only to
// 2^-24 * d^2 / near, 12 m at 10 km behind a 0.5 m near plane, which is the whole error of a
// depth read at a far silhouette.
inline constexpr float kBackgroundDepth = 0.0f;

// The camera's view-projection in the render frame (camera at the origin, x east, y north =
// world -y, z up), as render() draws with.
glm::mat4 view_projection(const Camera& camera, int32_t width, int32_t height);
// The world point under pixel (px, py) (row 0 at the top) whose window depth is `depth`
// (0..1, as the depth buffer holds it); nullopt for the background (depth 0).
std::optional<std::array<double, 3>> unproject(const Camera& camera, int32_t width, int32_t height, double px,
                                               double py, float depth);
// The distance along the view axis (m) of window depth `depth`, for the background the far
// plane's.
double view_distance(const Camera& camera, float depth);

}  // namespace loam::scene
