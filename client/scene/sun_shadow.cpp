#include "client/scene/sun_shadow.h"

#include <algorithm>
#include <cmath>

namespace loam::scene {

SunShadowFrame sun_shadow_frame(const Camera& camera, const glm::dvec3& to_sun, double radius_m, double min_z,
                                double max_z, int32_t texels) {
  SunShadowFrame s;
  const glm::dvec3 d = glm::normalize(to_sun);
  // Light axes: right and up across the map, d along it toward the sun.
  const glm::dvec3 up_hint = std::abs(d.z) > 0.999 ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1);
  const glm::dvec3 r = glm::normalize(glm::cross(-d, up_hint));
  const glm::dvec3 u = glm::cross(r, -d);
  // The square's centre: ahead of the camera by a third of the radius (what a view shows),
  // at the middle of the terrain's heights. Render frame, absolute: y north = -world y.
  double hx = camera.fx, hy = -camera.fy;
  const double hl = std::hypot(hx, hy);
  hx = hl > 1e-9 ? hx / hl : 0.0, hy = hl > 1e-9 ? hy / hl : 0.0;
  const glm::dvec3 cam_abs(camera.x, -camera.y, camera.z);
  const glm::dvec3 centre_abs(camera.x + hx * radius_m / 3.0, -camera.y + hy * radius_m / 3.0,
                              0.5 * (min_z + max_z));
  s.half_extent_m = radius_m;
  s.texel_m = 2.0 * radius_m / double(std::max(texels, 1));
  // Snap the centre's light-space position to whole texels (in absolute coordinates), then
  // express it relative to the camera.
  const double cr = std::round(glm::dot(centre_abs, r) / s.texel_m) * s.texel_m - glm::dot(cam_abs, r);
  const double cu = std::round(glm::dot(centre_abs, u) / s.texel_m) * s.texel_m - glm::dot(cam_abs, u);
  const double cd = glm::dot(centre_abs - cam_abs, d);
  // Depth covers the square's terrain from any sun angle: the radius plus the height range.
  const double depth = radius_m * 1.5 + (max_z - min_z) + 10.0;
  glm::dmat4 m(0.0);
  for (int k = 0; k < 3; ++k) {
    m[k][0] = r[k] / radius_m;
    m[k][1] = u[k] / radius_m;
    m[k][2] = 0.5 * d[k] / depth;
  }
  m[3][0] = -cr / radius_m;
  m[3][1] = -cu / radius_m;
  m[3][2] = 0.5 - 0.5 * cd / depth;
  m[3][3] = 1.0;
  s.light_view_proj = glm::mat4(m);
  return s;
}

}  // namespace loam::scene
