#include "client/controls/roam_path.h"

#include <cmath>

namespace loam::controls {

std::pair<double, double> roam_position(const WorldParams& world, uint32_t seed, double speed_mps, double t) {
  constexpr double kPi = 3.14159265358979323846;
  const RectI r = world.sample_rect();
  const double mps = world.meters_per_sample;
  const double cx = 0.5 * double(r.x0 + r.x1) * mps, cy = 0.5 * double(r.y0 + r.y1) * mps;
  const double ax = 0.35 * double(r.width()) * mps, ay = 0.35 * double(r.height()) * mps;
  // Ramanujan's perimeter of the ellipse: the angle advances by speed / perimeter turns a second.
  const double h = (ax - ay) * (ax - ay) / ((ax + ay) * (ax + ay));
  const double perimeter = kPi * (ax + ay) * (1 + 3 * h / (10 + std::sqrt(4 - 3 * h)));
  const double angle = double(seed % 360) * kPi / 180.0 + 2 * kPi * speed_mps * t / perimeter;
  return {cx + ax * std::cos(angle), cy + ay * std::sin(angle)};
}

}  // namespace loam::controls
