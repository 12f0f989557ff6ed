// The exact geometry under the terrain queries: a ray, and a translating sphere or capsule,
// against one triangle. Pure functions of doubles; the terrain walk is terrain_query.h's.
//
// A sweep finds the first time of contact by conservative advancement along the separating
// direction (the closest pair's): each step moves the shape by (gap / closing speed), which
// the supporting plane through the triangle's closest point proves cannot pass the contact,
// so the time returned is never later than the true one and converges to it (one step for a
// face contact, a few for an edge or a vertex).
#pragma once

#include <glm/vec3.hpp>
#include <optional>

namespace loam::query {

struct Triangle {
  glm::dvec3 a{0.0}, b{0.0}, c{0.0};
};

// The first t in [0, t_max] where o + t * d meets the triangle (either side), or nullopt.
// Points on an edge count for both triangles sharing it.
std::optional<double> ray_triangle(const glm::dvec3& o, const glm::dvec3& d, const Triangle& tri,
                                   double t_max);

// The point of the triangle nearest p.
glm::dvec3 closest_point_on_triangle(const glm::dvec3& p, const Triangle& tri);

// The closest points of segments p1-q1 and p2-q2 (either may be a point).
struct SegmentPair {
  glm::dvec3 on_first{0.0}, on_second{0.0};
};
SegmentPair closest_segment_segment(const glm::dvec3& p1, const glm::dvec3& q1, const glm::dvec3& p2,
                                    const glm::dvec3& q2);

// The closest points of segment p-q (p == q: a point) and a triangle; distance 0 where they cross.
struct SegmentTrianglePair {
  glm::dvec3 on_segment{0.0}, on_triangle{0.0};
  double distance = 0.0;
};
SegmentTrianglePair closest_segment_triangle(const glm::dvec3& p, const glm::dvec3& q, const Triangle& tri);

// A capsule (core segment p-q, radius r; p == q is a sphere) moved by t * motion, t in [0, 1].
struct Capsule {
  glm::dvec3 p{0.0}, q{0.0};
  double radius = 0.0;
};

struct SweepContact {
  double t = 0.0;               // fraction of the motion at first contact
  glm::dvec3 point{0.0};        // on the triangle
  glm::dvec3 normal{0.0};       // unit, from the triangle toward the shape's core
  bool started_inside = false;  // the shape already reached the triangle at t = 0
};

// The first contact of the moving capsule with the triangle within the motion, to within
// `tolerance` meters of gap, or nullopt when it never comes within its radius.
std::optional<SweepContact> sweep_capsule_triangle(const Capsule& shape, const glm::dvec3& motion,
                                                   const Triangle& tri, double tolerance = 1e-7);

// The triangle's unit normal, z up (for a terrain triangle), or z up when degenerate.
glm::dvec3 upward_normal(const Triangle& tri);

}  // namespace loam::query
