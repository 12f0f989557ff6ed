#include "client/controls/stamp_tool.h"

#include <algorithm>
#include <numbers>

namespace loam::controls {

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

void StampTool::select(Tool preset) {
  layer = Layer::kCoarse;
  blend = BlendMode::kAdd;
  volume_conserving = false;
  spin = true;
  switch (preset) {
    case Tool::kCrater:
      kind = StampKind::kCrater;
      intensity = 0.25 * radius_m;  // depth: a quarter of the radius
      shape = 0.3;
      break;
    case Tool::kRaise:
    case Tool::kDig:
      kind = StampKind::kGaussian;
      intensity = (preset == Tool::kRaise ? 0.2 : -0.2) * radius_m;
      break;
    case Tool::kFootprint:
      // On the detail layer, a tenth of the tool's size.
      kind = StampKind::kFootprint;
      layer = Layer::kDetail;
      intensity = 0.15;
      break;
    case Tool::kFlatten:
      kind = StampKind::kFlatten;
      intensity = 0.8;
      break;
    case Tool::kShockwave:
      kind = StampKind::kShockwave;
      intensity = 0.05 * radius_m;
      steps = 60;
      speed = 0.6;
      damping = 0.02;
      break;
  }
}

void StampTool::set_kind(StampKind k) {
  if (k == kind) return;
  kind = k;
  layer = Layer::kCoarse;
  switch (k) {
    case StampKind::kCrater: intensity = 0.25 * radius_m; break;
    case StampKind::kGaussian: intensity = 0.2 * radius_m; break;
    case StampKind::kTexture: intensity = 0.1 * radius_m; break;
    case StampKind::kFootprint:
      layer = Layer::kDetail;
      intensity = 0.15;
      break;
    case StampKind::kFlatten: intensity = 0.8; break;
    case StampKind::kShockwave: intensity = 0.05 * radius_m; break;
  }
  if (k == StampKind::kFootprint || k == StampKind::kFlatten || k == StampKind::kShockwave)
    blend = BlendMode::kAdd;
}

void StampTool::grow(double factor) {
  const double r = std::clamp(radius_m * factor, min_radius_m, std::max(min_radius_m, max_radius_m));
  const bool scales = kind == StampKind::kCrater || kind == StampKind::kGaussian ||
                      kind == StampKind::kTexture || kind == StampKind::kShockwave;
  if (scales && radius_m > 0) intensity *= r / radius_m;
  radius_m = r;
}

StampParams StampTool::at(double x, double y, double z) {
  StampParams p;
  p.kind = kind;
  p.layer = layer;
  p.blend = blend;
  p.center_x = x;
  p.center_y = y;
  p.radius = kind == StampKind::kFootprint ? std::max(0.25, 0.1 * radius_m) : radius_m;
  const double turn = spin ? double(seed++ % 64) / 64.0 : 0.0;
  p.rotation = rotation_degrees * (std::numbers::pi / 180.0) + turn * 2.0 * std::numbers::pi;
  p.intensity = intensity;
  // Only the fields the kind has (the validator refuses the others set).
  if (kind == StampKind::kCrater || kind == StampKind::kFootprint || kind == StampKind::kFlatten)
    p.shape = shape;
  p.volume_conserving = kind == StampKind::kCrater && volume_conserving;
  if (kind == StampKind::kTexture) p.texture_id = texture_id;
  // Flatten levels toward the height clicked on; min and max blends clamp to it.
  if (kind == StampKind::kFlatten || blend == BlendMode::kMin || blend == BlendMode::kMax) p.target = z;
  if (kind == StampKind::kShockwave) {
    p.steps = steps;
    p.speed = speed;
    p.damping = damping;
  }
  return p;
}

}  // namespace loam::controls
