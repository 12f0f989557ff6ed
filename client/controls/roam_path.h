// A scripted walk across a world, for bots and load tests that move as players do: a loop (an
// ellipse over the middle 70% of each side) walked at a steady speed, entered at a point the
// seed chooses. Pure.
#pragma once

#include <cstdint>
#include <utility>

#include "protocol/geometry.h"

namespace loam::controls {

// Where a walker is `t` seconds after it started, in world meters.
std::pair<double, double> roam_position(const WorldParams& world, uint32_t seed, double speed_mps, double t);

}  // namespace loam::controls
