// The viewer's deformation tool: what a click at a point of the terrain asks the server for.
// Presets (keys 1-6) fill the fields for the common tools; the tool panel edits every field,
// so each stamp kind can be sent with any radius, intensity, rotation and blend (texture
// stamps with one of the server's registered images, craters volume-conserving or not).
// Pure logic: a click's point goes in, StampParams come out (validated by the caller against
// the world, as everything from a user).
#pragma once

#include <cstdint>

#include "protocol/stamps/stamp.h"

namespace loam::controls {

enum class Tool : uint8_t { kCrater, kRaise, kDig, kFootprint, kFlatten, kShockwave };
inline constexpr int kToolCount = 6;
const char* to_string(Tool t);

struct StampTool {
  StampKind kind = StampKind::kCrater;
  Layer layer = Layer::kCoarse;
  BlendMode blend = BlendMode::kAdd;
  double radius_m = 8.0;
  // The range grow() keeps the radius in; the viewer sets it from the world's spacing
  // (view_scale: half a sample to 500 samples).
  double min_radius_m = 0.5, max_radius_m = 500.0;
  // Meters, signed (crater and footprint: depth; gaussian and texture: height; shockwave: the
  // initial displacement); flatten: strength 0..1.
  double intensity = 2.0;
  double rotation_degrees = 0.0;
  bool spin = true;    // successive stamps turn by 1/64 turn (varied craters, tracks)
  double shape = 0.3;  // crater: the rim's height relative to the depth
  bool volume_conserving = false;
  uint32_t steps = 60;  // shockwave
  double speed = 0.6, damping = 0.02;
  uint64_t texture_id = 0;  // texture: a registered image's content id
  uint32_t seed = 0;        // counts stamps (the spin)

  // Fills the fields for a preset at the current radius.
  void select(Tool preset);
  // Another kind, with that kind's usual layer and intensity at the current radius (a
  // footprint's depth on the detail layer, a flatten's strength), the rest kept.
  void set_kind(StampKind k);
  // The stamp for a click on the terrain at (x, y), whose ground is at height `z` meters
  // (flatten levels toward it).
  StampParams at(double x, double y, double z);
  // Radius x factor, clamped to min_radius_m .. max_radius_m; heights of kinds that scale with the radius
  // (crater, gaussian, texture, shockwave) scale with it, so a preset keeps its proportions.
  void grow(double factor);
  void set_radius(double meters) { grow(meters / radius_m); }
};

}  // namespace loam::controls
