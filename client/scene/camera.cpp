#include "client/scene/camera.h"

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>

namespace loam::scene {

Camera look_at(double x, double y, double z, double tx, double ty, double tz) {
  Camera c;
  c.x = x, c.y = y, c.z = z;
  c.fx = tx - x, c.fy = ty - y, c.fz = tz - z;
  return c;
}

std::optional<std::string> look_at_problem(double x, double y, double z, double tx, double ty, double tz) {
  for (const double v : {x, y, z, tx, ty, tz}) {
    if (!std::isfinite(v)) return "camera and look point must be finite numbers";
  }
  const double fx = tx - x, fy = ty - y, fz = tz - z;
  const double length = std::sqrt(fx * fx + fy * fy + fz * fz);
  if (!(length >= 1e-3)) return "the camera is at its look point: there is no view direction";
  // The up vector is +z: the sideways axis is forward x up, which vanishes for a vertical view.
  if (std::hypot(fx, fy) <= 1e-4 * length)
    return "the view is straight up or down (parallel to the up vector): move the look point sideways";
  return std::nullopt;
}

glm::mat4 view_projection(const Camera& camera, int32_t width, int32_t height) {
  // The render frame: camera at the origin, x east, y north (world y flipped), z up.
  const glm::vec3 fwd(float(camera.fx), float(-camera.fy), float(camera.fz));
  const glm::vec3 up(float(camera.ux), float(-camera.uy), float(camera.uz));
  const glm::mat4 view = glm::lookAt(glm::vec3(0.0f), fwd, up);
  const float aspect = float(width) / float(std::max(height, 1));
  glm::mat4 proj;
  if (camera.ortho_half_height > 0) {
    const float hh = float(camera.ortho_half_height);
    // Near and far swapped: the far plane maps to depth 0, the near plane to 1 (reversed).
    proj = glm::orthoRH_ZO(-hh * aspect, hh * aspect, -hh, hh, float(camera.far_m), float(camera.near_m));
  } else {
    proj = glm::perspectiveRH_ZO(glm::radians(float(camera.fov_y_degrees)), aspect, float(camera.far_m),
                                 float(camera.near_m));
  }
  return proj * view;
}

std::optional<std::array<double, 3>> unproject(const Camera& camera, int32_t width, int32_t height, double px,
                                               double py, float depth) {
  if (!(depth > kBackgroundDepth) || width < 1 || height < 1) return std::nullopt;  // background
  const glm::mat4 inv = glm::inverse(view_projection(camera, width, height));
  const glm::vec4 ndc(float(2.0 * (px + 0.5) / width - 1.0), float(1.0 - 2.0 * (py + 0.5) / height), depth,
                      1.0f);
  const glm::vec4 rel = inv * ndc;
  if (rel.w == 0.0f) return std::nullopt;
  return std::array<double, 3>{camera.x + double(rel.x / rel.w), camera.y - double(rel.y / rel.w),
                               camera.z + double(rel.z / rel.w)};
}

double view_distance(const Camera& camera, float depth) {
  const double n = camera.near_m, f = camera.far_m, d = std::clamp(double(depth), 0.0, 1.0);
  if (camera.ortho_half_height > 0) return f - d * (f - n);
  // depth = n (f - D) / (D (f - n)), solved for D.
  return n * f / (d * (f - n) + n);
}

}  // namespace loam::scene
