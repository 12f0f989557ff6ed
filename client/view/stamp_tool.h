// The viewer's deformation tools: what a click at a point of the terrain asks the server for.
// Pure logic: a tool, a size and the point go in, StampParams come out (validated by the
// caller against the world, as everything from a user).
#pragma once

#include <cstdint>

#include "protocol/stamps/stamp.h"

namespace loam::view {

enum class Tool : uint8_t { kCrater, kRaise, kDig, kFootprint, kFlatten, kShockwave };
inline constexpr int kToolCount = 6;
const char* to_string(Tool t);

struct StampTool {
  Tool tool = Tool::kCrater;
  double radius_m = 8.0;  // the tool's size; footprints are a tenth of it, on the detail layer
  uint32_t seed = 0;      // varies the rotation of successive stamps

  // The stamp for a click on the terrain at (x, y), whose ground is at height `z` meters.
  StampParams at(double x, double y, double z);
  void grow(double factor);  // radius x factor, clamped to 0.5 .. 500 m
};

}  // namespace loam::view
