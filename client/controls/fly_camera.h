// The viewer's camera: a free-flying position with yaw and pitch, moved by keys and turned by
// the mouse, kept a little above the ground; and a scripted flight for the headless viewer
// (its orbit is client/scene/start_view.h's).
// Pure logic (no GL, no window): input and time go in, a scene::Camera comes out.
// World frame as everywhere: x east, y along +gy (south), z up, meters; yaw 0 looks along +x
// and grows toward +y (a right turn seen from above), pitch > 0 looks up.
#pragma once

#include <functional>

#include "client/scene/camera.h"

namespace loam::controls {

struct FlyInput {
  double forward = 0, right = 0, up = 0;  // -1..1 each (keys)
  bool fast = false;                      // x8 speed
  double turn_x = 0, turn_y = 0;          // mouse motion, pixels (right, down)
};

class FlyCamera {
 public:
  FlyCamera() = default;
  // Placed at (x, y, z) looking at (tx, ty, tz).
  static FlyCamera looking_at(double x, double y, double z, double tx, double ty, double tz);

  // Moves by `input` over `dt` seconds; `ground(x, y)` (meters) keeps the camera at least
  // `clearance` above the terrain.
  void update(const FlyInput& input, double dt, const std::function<double(double, double)>& ground,
              double clearance = 2.0);
  scene::Camera camera(double fov_y_degrees = 60.0, double far_m = 20000.0) const;

  double x() const { return x_; }
  double y() const { return y_; }
  double z() const { return z_; }
  double yaw() const { return yaw_; }
  double pitch() const { return pitch_; }
  double speed() const { return speed_; }  // meters per second at normal pace
  void set_speed(double s);                // clamped to 0.5 .. 5000
  // Moves the eye, keeping the direction (walk mode puts it at the walker's eye).
  void set_position(double x, double y, double z) { x_ = x, y_ = y, z_ = z; }
  double turn_rate = 0.003;  // radians per pixel

 private:
  double x_ = 0, y_ = 0, z_ = 100, yaw_ = 0, pitch_ = -0.3, speed_ = 40.0;
};

// The headless viewer's flight: along a circle of `radius` around (cx, cy) at `speed` m/s,
// `height` above the ground under the camera, looking ahead along the path (at the ground
// 600 m ahead): what a fast flyer sees, with new terrain coming into every level.
scene::Camera flight_camera(double cx, double cy, double radius, double height, double speed, double t,
                            const std::function<double(double, double)>& ground);

}  // namespace loam::controls
