// Checks a level-of-detail mesh on its CPU replica, whatever scheme made it (clipmaps,
// geomipmapping, quadtrees, tiled blocks): triangles in mip-0 sample coordinates must tile a
// rect with no crack, overlap, flipped triangle or T-junction. Pure logic: no GL.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "protocol/geometry.h"

namespace loam::lod {

struct ReplicaTriangle {
  std::array<int64_t, 3> x{}, y{};
  bool degenerate = false;
};

struct WatertightReport {
  int64_t triangles = 0, edges = 0, boundary_edges = 0;
  int64_t open_edges = 0;                 // used once, not on the outermost boundary: a crack
  int64_t overshared_edges = 0;           // used more than twice: overlapping geometry
  int64_t misoriented_edges = 0;          // used twice in the same direction: a flipped triangle
  int64_t t_junctions = 0;                // a vertex inside an edge with no degenerate triangle bridging it
  int64_t area2 = 0, expected_area2 = 0;  // twice the covered area (non-degenerate triangles)
  bool ok() const {
    return open_edges == 0 && overshared_edges == 0 && misoriented_edges == 0 && t_junctions == 0 &&
           area2 == expected_area2;
  }
  std::string describe() const;
};

// Checks that the triangles tile `outer` (mip-0 samples; vertices on its border are the
// outermost boundary) with no crack, overlap or T-junction.
WatertightReport check_watertight(const std::vector<ReplicaTriangle>& tris, const RectI& outer);

}  // namespace loam::lod
