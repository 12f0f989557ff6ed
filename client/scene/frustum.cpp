#include "client/scene/frustum.h"

namespace loam::scene {

Frustum frustum_of(const glm::mat4& view_proj) {
  // glm is column-major: row i of the matrix is column i of its transpose.
  const glm::mat4 t = glm::transpose(view_proj);
  Frustum f;
  for (int i = 0; i < 2; ++i) {
    f.planes[size_t(2 * i)] = t[3] + t[i];
    f.planes[size_t(2 * i + 1)] = t[3] - t[i];
  }
  // Clip z runs 0..w (camera.h: reversed depth, z = w at the near plane, 0 at the far).
  f.planes[4] = t[3] - t[2];
  f.planes[5] = t[2];
  return f;
}

bool box_outside(const Frustum& frustum, const glm::vec3& lo, const glm::vec3& hi) {
  for (const glm::vec4& pl : frustum.planes) {
    // The box corner farthest along the plane's normal: outside it, the whole box is.
    const glm::vec3 p(pl.x >= 0 ? hi.x : lo.x, pl.y >= 0 ? hi.y : lo.y, pl.z >= 0 ? hi.z : lo.z);
    if (glm::dot(glm::vec3(pl), p) + pl.w < 0) return true;
  }
  return false;
}

}  // namespace loam::scene
