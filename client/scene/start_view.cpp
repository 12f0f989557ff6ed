#include "client/scene/start_view.h"

#include <algorithm>
#include <cmath>

namespace loam::scene {

ViewScale view_scale(const WorldParams& world) {
  const RectI r = world.sample_rect();
  const double mps = world.meters_per_sample;
  ViewScale s;
  s.meters_per_sample = mps;
  s.focus_x = 0.5 * double(r.x0 + r.x1) * mps;
  s.focus_y = 0.5 * double(r.y0 + r.y1) * mps;
  const double shorter = double(std::min(r.width(), r.height())) * mps;
  s.radius_m = std::min(0.3 * shorter, std::max(1500.0, 64.0 * mps));
  // Looking down 11 degrees at the focus: the horizon stays in the upper third of the view.
  s.height_m = 0.2 * s.radius_m;
  // The orbit's far side and three radii beyond it: the horizon of a low orbit.
  s.far_m = 6.0 * s.radius_m;
  s.view_distance_m = std::max(4000.0, 2.5 * s.radius_m);
  s.fly_speed_mps = std::clamp(0.1 * s.radius_m, 1.0, 5000.0);
  s.tool_min_radius_m = 0.5 * mps;
  s.tool_max_radius_m = 500.0 * mps;
  s.tool_radius_m = std::clamp(s.radius_m / 40.0, s.tool_min_radius_m, s.tool_max_radius_m);
  return s;
}

Camera orbit_view(const ViewScale& s, double angle, const GroundFn& ground) {
  const double x = s.focus_x + s.radius_m * std::cos(angle), y = s.focus_y + s.radius_m * std::sin(angle);
  const double gz = ground ? ground(x, y) : 0.0, tz = ground ? ground(s.focus_x, s.focus_y) : 0.0;
  double z = std::max(gz, tz) + s.height_m;
  if (ground) {
    // The sight line at fraction f from the eye stands at z + f (tz - z); it must pass
    // `margin` above the ground there: z >= (g(f) + margin - f tz) / (1 - f). Up to 90% of the
    // way: near the focus the line comes down to the focus's ground by construction.
    // Sampled every sample or two (64 to 1,024 points): a ridge between points pokes through
    // the margin by no more than its slope over that spacing.
    const double margin = 0.02 * s.radius_m;
    const int steps = int(std::clamp(0.9 * s.radius_m / s.meters_per_sample, 64.0, 1024.0));
    for (int i = 1; i <= steps; ++i) {
      const double f = 0.9 * double(i) / double(steps);
      const double g = ground(x + f * (s.focus_x - x), y + f * (s.focus_y - y));
      z = std::max(z, (g + margin - f * tz) / (1.0 - f));
    }
  }
  Camera c = look_at(x, y, z, s.focus_x, s.focus_y, tz);
  c.far_m = std::max(s.far_m, 2.0 * std::hypot(s.radius_m, z - tz));
  return c;
}

std::array<double, 2> walker_spawn(const WorldParams& world, double x, double y) {
  const RectI r = world.sample_rect();
  const double mps = world.meters_per_sample,
               inset = std::min(1.0, 0.25 * double(std::min(r.width(), r.height())) * mps);
  const double x0 = double(r.x0) * mps + inset, x1 = double(r.x1 - 1) * mps - inset;
  const double y0 = double(r.y0) * mps + inset, y1 = double(r.y1 - 1) * mps - inset;
  return {std::clamp(x, x0, std::max(x0, x1)), std::clamp(y, y0, std::max(y0, y1))};
}

}  // namespace loam::scene
