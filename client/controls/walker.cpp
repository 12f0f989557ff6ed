#include "client/controls/walker.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <optional>

#include "client/query/terrain_query.h"

namespace loam::controls {

namespace {

// Kept between the capsule and what it touches, so the next sweep does not start in contact.
constexpr double kSkin = 1e-3;

query::Capsule capsule_at(const glm::dvec3& feet, const WalkerConfig& c) {
  return {feet + glm::dvec3{0, 0, c.radius}, feet + glm::dvec3{0, 0, std::max(c.radius, c.height - c.radius)},
          c.radius};
}

bool walkable(const glm::dvec3& n, const WalkerConfig& c) {
  return n.z >= std::cos(c.max_slope_degrees * std::numbers::pi / 180.0);
}

// Whether faces it touches hold it up together: in a crease (a narrow valley, a faceted crater
// floor) or a pit of three faces each face may be too steep to stand on while together,
// pushing from every side, they make a floor. Their summed normal then says how steep that
// floor is.
bool faces_hold(const glm::dvec3& normal_sum, const WalkerConfig& c, glm::dvec3& support) {
  if (glm::length(normal_sum) < 1e-9) return false;
  const glm::dvec3 n = glm::normalize(normal_sum);
  if (!walkable(n, c)) return false;
  support = n;
  return true;
}

// Moves the capsule by `motion`, sliding along what it meets (up to four contacts); returns
// whether what it met holds it up (a walkable face, or steep faces together), and that normal.
// Met by a second face while sliding along a first, it slides along the crease the two make;
// met by a third, it stops. Wedged so (most of the motion spent against two faces or more,
// however steep their crease) it rests on them: they hold it.
bool move_and_slide(Walker& w, const query::TerrainSnapshot& s, glm::dvec3 motion, const WalkerConfig& c,
                    glm::dvec3& support) {
  bool supported = false;
  std::optional<glm::dvec3> steep;  // the last face met that was too steep on its own
  glm::dvec3 steep_sum{0.0};        // every such face met
  glm::dvec3 planes[4];             // the faces met, for the creases they make
  int faces = 0;
  const glm::dvec3 start = w.feet;
  const double asked = glm::length(motion);
  for (int i = 0; i < 4 && glm::length(motion) > 1e-9; ++i) {
    const query::SweepResult r = query::sweep_capsule(s, capsule_at(w.feet, c), motion);
    if (!r.contact) {
      w.feet += motion;
      break;
    }
    const glm::dvec3 n = r.contact->normal;
    if (r.contact->started_inside) {
      // Already touching (the ground rose under it: a stamp, a steep step): out along the normal.
      w.feet += n * (kSkin + 0.02);
      continue;
    }
    // Up to the contact, less the skin along the motion.
    const double len = glm::length(motion);
    const double t = std::max(0.0, r.contact->t - kSkin / len);
    w.feet += motion * t;
    motion *= (1.0 - t);
    // Slide: the rest of the motion without its part into the surface; the velocity likewise.
    motion -= n * std::min(0.0, glm::dot(motion, n));
    w.velocity -= n * std::min(0.0, glm::dot(w.velocity, n));
    // Sliding back into a face met before: along the crease of the two, or, a third, not at all.
    for (int k = 0; k < faces; ++k) {
      if (glm::dot(motion, planes[k]) >= -1e-12) continue;
      const glm::dvec3 crease = glm::cross(planes[k], n);
      if (glm::length(crease) < 1e-9 || faces >= 2) {
        motion = glm::dvec3(0.0);
        w.velocity = glm::dvec3(0.0);
        break;
      }
      const glm::dvec3 d = glm::normalize(crease);
      motion = d * glm::dot(motion, d);
      w.velocity = d * glm::dot(w.velocity, d);
      break;
    }
    if (faces < 4) planes[faces++] = n;
    if (walkable(n, c)) {
      supported = true;
      support = n;
    } else if (!supported && steep &&
               (faces_hold(*steep + n, c, support) || faces_hold(steep_sum + n, c, support))) {
      supported = true;
    } else {
      steep = n;
      steep_sum += n;
    }
  }
  if (!supported && faces >= 2 && asked > 1e-9 && glm::length(w.feet - start) < 0.1 * asked &&
      steep_sum.z > 1e-3) {
    supported = true;
    support = glm::normalize(steep_sum);
  }
  return supported;
}

// A short probe down from the feet (`probe` metres): whether the ground there holds the walker
// (a walkable face, or up to three steep faces it slides between), where, and its normal.
bool probe_ground(Walker& w, const query::TerrainSnapshot& s, double probe, const WalkerConfig& c,
                  glm::dvec3& support) {
  glm::dvec3 at = w.feet, rest{0.0, 0.0, -probe}, sum{0.0}, first{0.0};
  for (int k = 0; k < 3; ++k) {
    const double len = glm::length(rest);
    if (len < 1e-9) return false;
    const query::SweepResult r = query::sweep_capsule(s, capsule_at(at, c), rest);
    if (!r.contact || r.contact->started_inside) return false;
    const glm::dvec3 n = r.contact->normal;
    at += rest * std::max(0.0, r.contact->t - kSkin / len);
    if (k == 0 && walkable(n, c)) {
      w.feet = at;
      support = n;
      return true;
    }
    sum += n;
    if (k > 0 && faces_hold(sum, c, support)) {
      w.feet = at;
      return true;
    }
    // Wedged between faces it cannot slide between (a third one stops the crease at once): it
    // rests on them.
    if (k == 2 && glm::length(at - w.feet) < 0.01 && sum.z > 1e-3) {
      w.feet = at;
      support = glm::normalize(sum);
      return true;
    }
    // The rest of the probe along the face (after two faces, along the crease they make).
    rest *= 1.0 - r.contact->t;
    if (k == 0) {
      first = n;
      rest -= n * glm::dot(rest, n);
    } else {
      const glm::dvec3 crease = glm::cross(first, n);
      if (glm::length(crease) < 1e-9) return false;
      const glm::dvec3 d = glm::normalize(crease);
      rest = d * glm::dot(rest, d);
    }
  }
  return false;
}

void substep(Walker& w, const query::TerrainSnapshot& s, const WalkerInput& in, double dt,
             const WalkerConfig& c) {
  // Where the input asks to go, horizontally.
  const glm::dvec3 fwd{std::cos(in.yaw), std::sin(in.yaw), 0.0},
      right{-std::sin(in.yaw), std::cos(in.yaw), 0.0};
  glm::dvec3 wish = fwd * std::clamp(in.forward, -1.0, 1.0) + right * std::clamp(in.right, -1.0, 1.0);
  if (glm::length(wish) > 1.0) wish = glm::normalize(wish);
  wish *= in.run ? c.run_speed : c.walk_speed;

  const bool was_grounded = w.grounded;
  bool jumped = false;
  if (w.grounded) {
    // On the ground: walk along its plane at the wished speed; a jump leaves it.
    const glm::dvec3 n = w.ground_normal;
    glm::dvec3 along = wish - n * glm::dot(wish, n);
    if (glm::length(along) > 1e-12) along = glm::normalize(along) * glm::length(wish);
    w.velocity = along;
    if (in.jump) {
      w.velocity.z += c.jump_speed;
      w.grounded = false;
      jumped = true;
    }
  } else {
    // In the air: gravity, and a little steering.
    const glm::dvec3 horiz{w.velocity.x, w.velocity.y, 0.0};
    const glm::dvec3 steer = (wish - horiz) * std::min(1.0, c.air_control * 10.0 * dt);
    w.velocity += glm::dvec3{steer.x, steer.y, -c.gravity * dt};
  }

  glm::dvec3 support{0.0, 0.0, 1.0};
  bool supported = move_and_slide(w, s, w.velocity * dt, c, support);
  // Still touching below? A short probe down finds the ground it stands on (and, walking,
  // follows it up and down a slope or a step of up to snap_distance instead of leaving it).
  // Walking uphill moves it up along the ground; only a jump or a fall's rise leaves it.
  const bool walking = was_grounded && !jumped;
  if (!supported && (walking || w.velocity.z <= 1e-9))
    supported = probe_ground(w, s, walking ? c.snap_distance : 2.0 * kSkin, c, support);
  if (supported && (walking || w.velocity.z <= 1e-9)) {
    w.grounded = true;
    w.ground_normal = support;
    if (!walking) w.velocity.z = 0.0;
    w.airborne_s = 0;
  } else {
    w.grounded = false;
    w.airborne_s += dt;
  }
}

}  // namespace

Walker place_walker(const query::TerrainSnapshot& s, double x, double y, const WalkerConfig& config) {
  Walker w;
  const auto h = query::height_at(s, x, y);
  w.feet = {x, y, h.value_or(0.0)};
  if (h) {
    // Standing on the highest ground under the capsule's footprint.
    const query::SweepResult r =
        query::sweep_capsule(s, capsule_at(w.feet + glm::dvec3{0, 0, 50.0}, config), {0.0, 0.0, -60.0});
    if (r.contact) w.feet.z = w.feet.z + 50.0 - 60.0 * r.contact->t + kSkin;
    w.grounded = r.contact.has_value() && walkable(r.contact->normal, config);
    if (w.grounded) w.ground_normal = r.contact->normal;
  }
  return w;
}

void step_walker(Walker& w, const query::TerrainSnapshot& s, const WalkerInput& input, double dt,
                 const WalkerConfig& config) {
  if (!(dt > 0.0) || !std::isfinite(dt)) return;
  const int steps = int(std::ceil(dt * 120.0 - 1e-9));
  WalkerInput in = input;
  for (int i = 0; i < steps; ++i) {
    substep(w, s, in, dt / steps, config);
    in.jump = false;  // one take-off per call
  }
}

}  // namespace loam::controls
