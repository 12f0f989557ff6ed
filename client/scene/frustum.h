// View-frustum culling without GL: the six planes of a view-projection matrix (Gribb &
// Hartmann: rows of the matrix added and subtracted) and the test every level-of-detail scheme
// runs on its pieces' bounding boxes. Conservative: a box is culled only when it lies entirely
// outside one plane, so a box near a frustum corner may be kept although it is outside.
#pragma once

#include <array>
#include <glm/glm.hpp>

namespace loam::scene {

struct Frustum {
  // left, right, bottom, top, near, far; a point p is inside plane q when dot(q.xyz, p) + q.w >= 0.
  std::array<glm::vec4, 6> planes;
};

// The frustum of a view-projection matrix (OpenGL clip space, -w <= x, y, z <= w), in the frame
// the matrix maps from (the renderer's camera-relative frame).
Frustum frustum_of(const glm::mat4& view_proj);

// An axis-aligned box [lo, hi] lies entirely outside at least one plane.
bool box_outside(const Frustum& frustum, const glm::vec3& lo, const glm::vec3& hi);

}  // namespace loam::scene
