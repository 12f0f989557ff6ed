// Where a viewer starts on a world, and the scales of its controls there. The windowed and the
// headless viewer both look at the session's focus (the world's centre) from an orbit whose
// radius suits the world's size and sample spacing, high enough that the sight line clears
// every ridge in between; the fly speed, the stamp tool's radius and its range follow from the
// same numbers, so a 2 km crop, the 131 km refined world and a 90 m DEM all start on terrain
// with controls that fit. Pure logic (no GL, no window): world parameters and a ground
// function go in.
#pragma once

#include <array>
#include <functional>

#include "client/scene/camera.h"
#include "protocol/world.h"

namespace loam::scene {

// Ground height (m) at a world point (x, y in m).
using GroundFn = std::function<double(double, double)>;

struct ViewScale {
  double focus_x = 0, focus_y = 0;  // the world's centre, m
  double meters_per_sample = 1;     // the world's spacing
  double radius_m = 0;              // the eye's horizontal distance from the focus
  double height_m = 0;              // the eye above the higher of its ground and the focus's
  double far_m = 0;                 // far plane: the whole orbit and what lies beyond it
  double view_distance_m = 0;       // the clipmap's reach: 4 km, or 2.5 radii on coarse worlds
  double fly_speed_mps = 0;         // crosses the orbit's radius in 10 s
  double tool_radius_m = 0;         // the stamp tool's radius at the start: visible from the orbit
  double tool_min_radius_m = 0;     // half a sample: finer stamps change nothing
  double tool_max_radius_m = 0;     // 500 samples (the server's default limit is 4096)
};

// The scales of `world`: the orbit's radius is 30% of the world's shorter side, at most
// max(1.5 km, 64 samples) (what a player sees, not the whole world from afar).
ViewScale view_scale(const WorldParams& world);

// The orbit's eye at `angle` radians (0: east of the focus, growing toward +y), looking at the
// focus's ground, `s.height_m` above the higher of the ground under it and the focus's, then
// raised until the sight line clears the ground between them by 2% of the radius.
Camera orbit_view(const ViewScale& s, double angle, const GroundFn& ground);

// Where a walker starts from an eye at (x, y): the nearest point at least a metre inside the
// world (an eye flown past the edge puts its walker on the world's rim).
std::array<double, 2> walker_spawn(const WorldParams& world, double x, double y);

}  // namespace loam::scene
