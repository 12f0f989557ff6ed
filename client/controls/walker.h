// The viewer's walk mode and a game's character: a capsule that walks on the terrain the
// player sees, through the query API (client/query/terrain_query.h). Newtonian, as the
// deformable-terrain paper's camera: gravity accelerates it, the terrain stops it, and it slides
// along what it touches. It stands on slopes up to a limit and slides down steeper ones, follows
// the ground down steps and slopes while walking, jumps, and falls into a crater dug under it.
// Pure logic (no GL, no network): a snapshot, input and time go in, a new state comes out.
// World frame: x east, y along +gy, z up, meters; yaw 0 walks along +x, growing toward +y.
#pragma once

#include <glm/vec3.hpp>

#include "client/query/terrain_snapshot.h"

namespace loam::controls {

struct WalkerConfig {
  double radius = 0.3;            // capsule radius, m
  double height = 1.8;            // feet to top of head, m
  double eye_height = 1.65;       // above the feet
  double walk_speed = 1.4;        // m/s
  double run_speed = 5.0;         // m/s
  double jump_speed = 4.0;        // m/s upward at take-off
  double gravity = 9.81;          // m/s^2
  double max_slope_degrees = 45;  // steeper ground does not hold it
  double snap_distance = 0.3;     // how far down it follows the ground while walking, m
  double air_control = 0.1;       // fraction of walking acceleration in the air
};

struct WalkerInput {
  double forward = 0, right = 0;  // -1..1 each
  double yaw = 0;                 // radians, the facing direction
  bool run = false;
  bool jump = false;  // take off when standing
};

struct Walker {
  glm::dvec3 feet{0.0};      // the bottom of the capsule
  glm::dvec3 velocity{0.0};  // m/s
  bool grounded = false;     // standing on walkable ground
  glm::dvec3 ground_normal{0.0, 0.0, 1.0};
  double airborne_s = 0;  // time since it last stood
};

// A walker standing on the ground at (x, y); stays in the air where the terrain there is not loaded.
Walker place_walker(const query::TerrainSnapshot& s, double x, double y, const WalkerConfig& config = {});

// Advances the walker by `dt` seconds (split into steps of at most 1/120 s).
void step_walker(Walker& w, const query::TerrainSnapshot& s, const WalkerInput& input, double dt,
                 const WalkerConfig& config = {});

// The eye: feet plus eye height.
inline glm::dvec3 walker_eye(const Walker& w, const WalkerConfig& config = {}) {
  return w.feet + glm::dvec3{0.0, 0.0, config.eye_height};
}

}  // namespace loam::controls
