#include "client/lod/mesh_check.h"

#include <algorithm>
#include <cstdlib>
#include <numeric>
#include <unordered_map>
#include <unordered_set>

namespace loam::lod {

namespace {

struct PairHash {
  size_t operator()(const std::pair<int64_t, int64_t>& p) const {
    uint64_t k = uint64_t(p.first) * 0x9E3779B97F4A7C15ull ^ (uint64_t(p.second) + 0x632BE59BD9B4E019ull);
    k ^= k >> 31;
    k *= 0xBF58476D1CE4E5B9ull;
    return size_t(k ^ (k >> 29));
  }
};

}  // namespace

std::string WatertightReport::describe() const {
  return "triangles " + std::to_string(triangles) + ", edges " + std::to_string(edges) + " (boundary " +
         std::to_string(boundary_edges) + "), open " + std::to_string(open_edges) + ", overshared " +
         std::to_string(overshared_edges) + ", misoriented " + std::to_string(misoriented_edges) +
         ", T-junctions " + std::to_string(t_junctions) + ", area2 " + std::to_string(area2) + " of " +
         std::to_string(expected_area2);
}

WatertightReport check_watertight(const std::vector<ReplicaTriangle>& tris, const RectI& outer) {
  WatertightReport r;
  std::unordered_map<std::pair<int64_t, int64_t>, uint32_t, PairHash> vertex;
  auto vid = [&](int64_t x, int64_t y) {
    return vertex.try_emplace({x, y}, uint32_t(vertex.size())).first->second;
  };
  std::vector<std::array<uint32_t, 3>> ids(tris.size());
  for (size_t t = 0; t < tris.size(); ++t) {
    for (size_t k = 0; k < 3; ++k) ids[t][k] = vid(tris[t].x[k], tris[t].y[k]);
  }
  std::unordered_map<std::pair<int64_t, int64_t>, int32_t, PairHash> directed;
  std::unordered_set<std::pair<int64_t, int64_t>, PairHash> undirected;
  std::unordered_set<std::pair<int64_t, int64_t>, PairHash> bridges;  // (edge key, middle vertex)
  auto ekey = [](uint32_t a, uint32_t b) {
    return std::pair<int64_t, int64_t>(std::min(a, b), std::max(a, b));
  };
  for (size_t t = 0; t < tris.size(); ++t) {
    const ReplicaTriangle& tr = tris[t];
    for (size_t k = 0; k < 3; ++k) {
      const uint32_t a = ids[t][k], b = ids[t][(k + 1) % 3];
      ++directed[{a, b}];
      undirected.insert(ekey(a, b));
    }
    if (tr.degenerate) {
      // The middle vertex of a degenerate triangle bridges the edge between the other two.
      const auto [a, c] = ekey(ids[t][0], ids[t][2]);
      const uint64_t e = uint64_t(a) << 32 | uint64_t(c);
      bridges.insert({int64_t(e), ids[t][1]});
      continue;
    }
    ++r.triangles;
    r.area2 += (tr.x[1] - tr.x[0]) * (tr.y[2] - tr.y[0]) - (tr.x[2] - tr.x[0]) * (tr.y[1] - tr.y[0]);
  }
  const int64_t xl = outer.x1 - 1, yl = outer.y1 - 1;
  r.expected_area2 = 2 * (xl - outer.x0) * (yl - outer.y0);
  std::vector<std::pair<int64_t, int64_t>> pos(vertex.size());
  for (const auto& [p, id] : vertex) pos[id] = p;
  for (const auto& e : undirected) {
    ++r.edges;
    const uint32_t a = uint32_t(e.first), b = uint32_t(e.second);
    const auto ab = directed.find({a, b}), ba = directed.find({b, a});
    const int32_t cab = ab == directed.end() ? 0 : ab->second, cba = ba == directed.end() ? 0 : ba->second;
    const auto [ax, ay] = pos[a];
    const auto [bx, by] = pos[b];
    if (cab + cba == 1) {
      const bool on_border =
          (ax == bx && (ax == outer.x0 || ax == xl)) || (ay == by && (ay == outer.y0 || ay == yl));
      on_border ? ++r.boundary_edges : ++r.open_edges;
    } else if (cab + cba > 2) {
      ++r.overshared_edges;
    } else if (cab != cba) {
      ++r.misoriented_edges;
    }
  }
  // A vertex strictly inside an edge of a real triangle is a T-junction unless a degenerate
  // triangle (edge ends + that vertex) closes it.
  for (size_t t = 0; t < tris.size(); ++t) {
    if (tris[t].degenerate) continue;
    for (size_t k = 0; k < 3; ++k) {
      const uint32_t a = ids[t][k], b = ids[t][(k + 1) % 3];
      const auto [ax, ay] = pos[a];
      const auto [bx, by] = pos[b];
      const int64_t dx = bx - ax, dy = by - ay, g = std::gcd(std::abs(dx), std::abs(dy));
      for (int64_t i = 1; i < g; ++i) {
        const auto it = vertex.find({ax + dx / g * i, ay + dy / g * i});
        if (it == vertex.end()) continue;
        const auto [lo, hi] = ekey(a, b);
        if (!bridges.count({int64_t(uint64_t(lo) << 32 | uint64_t(hi)), it->second})) ++r.t_junctions;
      }
    }
  }
  return r;
}

}  // namespace loam::lod
