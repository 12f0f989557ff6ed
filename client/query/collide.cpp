#include "client/query/collide.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

namespace loam::query {

namespace {

// Barycentric slack for points on a shared edge: both triangles claim them.
constexpr double kEdgeSlack = 1e-12;

}  // namespace

std::optional<double> ray_triangle(const glm::dvec3& o, const glm::dvec3& d, const Triangle& tri,
                                   double t_max) {
  const glm::dvec3 e1 = tri.b - tri.a, e2 = tri.c - tri.a;
  const glm::dvec3 pv = glm::cross(d, e2);
  const double det = glm::dot(e1, pv);
  // Parallel to the plane (or a degenerate triangle): a ray in the plane meets its edges,
  // which the neighbouring triangles (not parallel to it) report.
  if (std::fabs(det) <= 1e-300 || !std::isfinite(det)) return std::nullopt;
  const double inv = 1.0 / det;
  const glm::dvec3 tv = o - tri.a;
  const double u = glm::dot(tv, pv) * inv;
  if (u < -kEdgeSlack || u > 1.0 + kEdgeSlack) return std::nullopt;
  const glm::dvec3 qv = glm::cross(tv, e1);
  const double v = glm::dot(d, qv) * inv;
  if (v < -kEdgeSlack || u + v > 1.0 + kEdgeSlack) return std::nullopt;
  const double t = glm::dot(e2, qv) * inv;
  if (t < 0.0 || t > t_max) return std::nullopt;
  return t;
}

glm::dvec3 closest_point_on_triangle(const glm::dvec3& p, const Triangle& tri) {
  // Voronoi regions of the vertices, then the edges, then the face.
  const glm::dvec3 ab = tri.b - tri.a, ac = tri.c - tri.a, ap = p - tri.a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) return tri.a;
  const glm::dvec3 bp = p - tri.b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return tri.b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return tri.a + ab * (d1 / (d1 - d3));
  const glm::dvec3 cp = p - tri.c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return tri.c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return tri.a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    return tri.b + (tri.c - tri.b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  }
  const double denom = va + vb + vc;
  if (denom <= 0.0) return tri.a;  // degenerate triangle
  return tri.a + ab * (vb / denom) + ac * (vc / denom);
}

SegmentPair closest_segment_segment(const glm::dvec3& p1, const glm::dvec3& q1, const glm::dvec3& p2,
                                    const glm::dvec3& q2) {
  const glm::dvec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = glm::dot(d1, d1), e = glm::dot(d2, d2), f = glm::dot(d2, r);
  constexpr double kTiny = 1e-24;
  double s = 0.0, t = 0.0;
  if (a <= kTiny && e <= kTiny) {
    // both points
  } else if (a <= kTiny) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = glm::dot(d1, r);
    if (e <= kTiny) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = glm::dot(d1, d2), denom = a * e - b * b;
      s = denom > 0.0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return {p1 + d1 * s, p2 + d2 * t};
}

SegmentTrianglePair closest_segment_triangle(const glm::dvec3& p, const glm::dvec3& q, const Triangle& tri) {
  const glm::dvec3 pq = q - p;
  if (glm::dot(pq, pq) > 0.0) {
    if (const auto t = ray_triangle(p, pq, tri, 1.0)) {
      const glm::dvec3 x = p + pq * *t;
      return {x, x, 0.0};
    }
  }
  // Apart: the closest pair has an end of the segment against the triangle, or the segment
  // against an edge.
  SegmentTrianglePair best;
  best.distance = INFINITY;
  auto consider = [&](const glm::dvec3& on_seg, const glm::dvec3& on_tri) {
    const double dist = glm::length(on_seg - on_tri);
    if (dist < best.distance) best = {on_seg, on_tri, dist};
  };
  consider(p, closest_point_on_triangle(p, tri));
  if (glm::dot(pq, pq) == 0.0) return best;
  consider(q, closest_point_on_triangle(q, tri));
  const glm::dvec3* v[3] = {&tri.a, &tri.b, &tri.c};
  for (int i = 0; i < 3; ++i) {
    const SegmentPair sp = closest_segment_segment(p, q, *v[i], *v[(i + 1) % 3]);
    consider(sp.on_first, sp.on_second);
  }
  return best;
}

glm::dvec3 upward_normal(const Triangle& tri) {
  glm::dvec3 n = glm::cross(tri.b - tri.a, tri.c - tri.a);
  const double len = glm::length(n);
  if (!(len > 0.0)) return {0.0, 0.0, 1.0};
  n /= len;
  return n.z < 0.0 ? -n : n;
}

std::optional<SweepContact> sweep_capsule_triangle(const Capsule& shape, const glm::dvec3& motion,
                                                   const Triangle& tri, double tolerance) {
  double t = 0.0;
  for (int iter = 0; iter < 64; ++iter) {
    const glm::dvec3 off = motion * t;
    const SegmentTrianglePair cp = closest_segment_triangle(shape.p + off, shape.q + off, tri);
    const double gap = cp.distance - shape.radius;
    glm::dvec3 toward_shape = cp.on_segment - cp.on_triangle;
    const double len = glm::length(toward_shape);
    toward_shape = len > 0.0 ? toward_shape / len : upward_normal(tri);
    if (gap <= tolerance) {
      SweepContact c;
      c.t = t;
      c.point = cp.on_triangle;
      c.normal = toward_shape;
      c.started_inside = iter == 0 && gap < -tolerance;
      return c;
    }
    // The triangle lies beyond the plane through its closest point, facing the shape: the
    // shape reaches it no sooner than when it has closed the gap along that plane's normal.
    const double closing = -glm::dot(motion, toward_shape);
    if (!(closing > 0.0)) return std::nullopt;
    t += gap / closing;
    if (t > 1.0) return std::nullopt;
  }
  // Not converged (a grazing approach): t is still no later than the contact.
  const glm::dvec3 off = motion * t;
  const SegmentTrianglePair cp = closest_segment_triangle(shape.p + off, shape.q + off, tri);
  if (cp.distance - shape.radius > std::max(1e-3, 0.01 * shape.radius)) return std::nullopt;
  SweepContact c;
  c.t = t;
  c.point = cp.on_triangle;
  const glm::dvec3 d = cp.on_segment - cp.on_triangle;
  c.normal = glm::length(d) > 0.0 ? glm::normalize(d) : upward_normal(tri);
  return c;
}

}  // namespace loam::query
