// Height and collision queries on a TerrainSnapshot, for game code: the height and normal at a
// point, a raycast, and a sphere or capsule swept against the terrain.
//
// The surface is the one the player sees drawn at full resolution: the coarse samples as
// triangles, every cell split along its (x, y)-(x+1, y+1) diagonal as the renderer splits it,
// plus the detail layer's offsets triangulated the same way on its finer grid (its cells nest
// in the coarse triangles, so the sum is planar on each detail triangle). A height query at a
// sample's position returns that sample exactly; between samples it is the triangle's plane,
// and the normal is that plane's (the gradient of the height). World meters: x = global
// sample x * meters_per_sample, y likewise, z up.
//
// Only held tiles are known: a query needing a sample of a tile the snapshot does not hold
// answers nullopt (height, normal), and a ray or sweep reports `reached_unheld` when its path
// crossed such a cell (it passes through it, as through open air).
#pragma once

#include <glm/vec3.hpp>
#include <optional>

#include "client/query/collide.h"
#include "client/query/terrain_snapshot.h"

namespace loam::query {

std::optional<double> height_at(const TerrainSnapshot& s, double x, double y);
std::optional<glm::dvec3> normal_at(const TerrainSnapshot& s, double x, double y);

struct RayHit {
  double distance = 0.0;  // along the normalized direction, meters
  glm::dvec3 point{0.0};
  glm::dvec3 normal{0.0};  // the hit triangle's, z up
};
struct RayResult {
  std::optional<RayHit> hit;
  bool reached_unheld = false;
};
// The first point of the surface along origin + t * normalize(direction), t in [0, max_distance].
RayResult raycast(const TerrainSnapshot& s, const glm::dvec3& origin, const glm::dvec3& direction,
                  double max_distance);

struct SweepResult {
  std::optional<SweepContact> contact;  // t: fraction of the motion at first contact
  bool reached_unheld = false;
};
// A sphere (center, radius) or capsule moved by `motion`: its first contact with the surface.
SweepResult sweep_sphere(const TerrainSnapshot& s, const glm::dvec3& center, double radius,
                         const glm::dvec3& motion);
SweepResult sweep_capsule(const TerrainSnapshot& s, const Capsule& capsule, const glm::dvec3& motion);

// What one query looked at (for benchmarks and tests).
struct QueryWork {
  uint64_t blocks_visited = 0, blocks_skipped = 0, triangles_tested = 0;
};
RayResult raycast(const TerrainSnapshot& s, const glm::dvec3& origin, const glm::dvec3& direction,
                  double max_distance, QueryWork* work);
SweepResult sweep_capsule(const TerrainSnapshot& s, const Capsule& capsule, const glm::dvec3& motion,
                          QueryWork* work);

}  // namespace loam::query
