#include "client/controls/fly_camera.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "client/scene/camera.h"

namespace loam::controls {

FlyCamera FlyCamera::looking_at(double x, double y, double z, double tx, double ty, double tz) {
  FlyCamera c;
  c.x_ = x, c.y_ = y, c.z_ = z;
  const double dx = tx - x, dy = ty - y, dz = tz - z;
  c.yaw_ = std::atan2(dy, dx);
  c.pitch_ = std::atan2(dz, std::hypot(dx, dy));
  return c;
}

void FlyCamera::set_speed(double s) { speed_ = std::clamp(s, 0.5, 5000.0); }

void FlyCamera::update(const FlyInput& in, double dt, const std::function<double(double, double)>& ground,
                       double clearance) {
  yaw_ += in.turn_x * turn_rate;
  yaw_ = std::remainder(yaw_, 2.0 * std::numbers::pi);
  pitch_ = std::clamp(pitch_ - in.turn_y * turn_rate, -1.55, 1.55);
  const double v = speed_ * (in.fast ? 8.0 : 1.0) * dt;
  const double cy = std::cos(yaw_), sy = std::sin(yaw_), cp = std::cos(pitch_), sp = std::sin(pitch_);
  // Forward along the view (so looking down and moving forward descends); right is a right
  // turn's direction: yaw + 90 degrees.
  x_ += v * (in.forward * cp * cy - in.right * sy);
  y_ += v * (in.forward * cp * sy + in.right * cy);
  z_ += v * (in.forward * sp + in.up);
  if (ground) z_ = std::max(z_, ground(x_, y_) + clearance);
}

scene::Camera FlyCamera::camera(double fov_y_degrees, double far_m) const {
  const double cp = std::cos(pitch_);
  scene::Camera c =
      scene::look_at(x_, y_, z_, x_ + cp * std::cos(yaw_), y_ + cp * std::sin(yaw_), z_ + std::sin(pitch_));
  c.fov_y_degrees = fov_y_degrees;
  c.far_m = far_m;
  return c;
}

scene::Camera flight_camera(double cx, double cy, double radius, double height, double speed, double t,
                            const std::function<double(double, double)>& ground) {
  const double a = speed * t / radius, ahead = 600.0 / radius;
  const double x = cx + radius * std::cos(a), y = cy + radius * std::sin(a);
  const double lx = cx + radius * std::cos(a + ahead), ly = cy + radius * std::sin(a + ahead);
  const double gz = ground ? ground(x, y) : 0.0, lz = ground ? ground(lx, ly) : 0.0;
  return scene::look_at(x, y, gz + height, lx, ly, lz);
}

}  // namespace loam::controls
