#include "client/view/stamp_tool.h"

#include <algorithm>

namespace loam::view {

const char* to_string(Tool t) {
  switch (t) {
    case Tool::kCrater: return "crater";
    case Tool::kRaise: return "raise";
    case Tool::kDig: return "dig";
    case Tool::kFootprint: return "footprint";
    case Tool::kFlatten: return "flatten";
    case Tool::kShockwave: return "shockwave";
  }
  return "?";
}

void StampTool::grow(double factor) { radius_m = std::clamp(radius_m * factor, 0.5, 500.0); }

StampParams StampTool::at(double x, double y, double z) {
  StampParams p;
  p.center_x = x;
  p.center_y = y;
  p.radius = radius_m;
  p.rotation = double(seed++ % 64) * (6.283185307179586 / 64.0);
  switch (tool) {
    case Tool::kCrater:
      p.kind = StampKind::kCrater;
      p.intensity = 0.25 * radius_m;  // depth: a quarter of the radius
      p.shape = 0.3;
      break;
    case Tool::kRaise:
    case Tool::kDig:
      p.kind = StampKind::kGaussian;
      p.intensity = (tool == Tool::kRaise ? 0.2 : -0.2) * radius_m;
      break;
    case Tool::kFootprint:
      p.kind = StampKind::kFootprint;
      p.layer = Layer::kDetail;
      p.radius = std::max(0.25, 0.1 * radius_m);
      p.intensity = 0.15;
      break;
    case Tool::kFlatten:
      p.kind = StampKind::kFlatten;
      p.intensity = 0.8;
      p.target = z;  // level the area to the height clicked on
      break;
    case Tool::kShockwave:
      p.kind = StampKind::kShockwave;
      p.intensity = 0.05 * radius_m;
      p.steps = 60;
      p.speed = 0.6;
      p.damping = 0.02;
      break;
  }
  return p;
}

}  // namespace loam::view
