#include "client/query/terrain_query.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <limits>
#include <utility>
#include <vector>

#include "protocol/surface.h"

namespace loam::query {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Reads samples of a snapshot by global index, remembering the last tile of each layer.
class SampleReader {
 public:
  explicit SampleReader(const TerrainSnapshot& s) : s_(s), world_(s.world_samples()) {}

  const TerrainSnapshot& snapshot() const { return s_; }
  const RectI& world() const { return world_; }

  std::optional<double> coarse_m(int64_t gx, int64_t gy) {
    if (gx < world_.x0 || gy < world_.y0 || gx >= world_.x1 || gy >= world_.y1) return std::nullopt;
    const int64_t tx = floor_div(gx, kTileSize), ty = floor_div(gy, kTileSize);
    if (tx != ctx_ || ty != cty_ || !coarse_looked_) {
      coarse_ = s_.coarse_tile(tx, ty);
      ctx_ = tx, cty_ = ty, coarse_looked_ = true;
    }
    if (coarse_ == nullptr) return std::nullopt;
    const size_t i = size_t(floor_mod(gy, kTileSize) * kTileSize + floor_mod(gx, kTileSize));
    return s_.params().height_meters(coarse_->samples[i]);
  }

  // 0 where no detail tile is held (as the renderer shows it).
  double detail_m(int64_t dx, int64_t dy) {
    if (s_.detail_tiles() == 0) return 0.0;
    const int64_t tx = floor_div(dx, kTileSize), ty = floor_div(dy, kTileSize);
    if (tx != dtx_ || ty != dty_ || !detail_looked_) {
      detail_ = s_.detail_tile(tx, ty);
      dtx_ = tx, dty_ = ty, detail_looked_ = true;
    }
    if (detail_ == nullptr) return 0.0;
    const size_t i = size_t(floor_mod(dy, kTileSize) * kTileSize + floor_mod(dx, kTileSize));
    return s_.params().detail_meters(detail_->samples[i]);
  }

  // Whether any detail sample of coarse cell (i, j), its far edges included, is held.
  bool cell_has_detail(int64_t i, int64_t j) const {
    if (s_.detail_tiles() == 0) return false;
    const int64_t f = s_.params().detail_factor;
    const int64_t tx0 = floor_div(i * f, kTileSize), tx1 = floor_div((i + 1) * f, kTileSize);
    const int64_t ty0 = floor_div(j * f, kTileSize), ty1 = floor_div((j + 1) * f, kTileSize);
    for (int64_t ty = ty0; ty <= ty1; ++ty) {
      for (int64_t tx = tx0; tx <= tx1; ++tx) {
        if (s_.detail_tile(tx, ty) != nullptr) return true;
      }
    }
    return false;
  }

  // Cells are [x0, x1 - 1) x [y0, y1 - 1): a cell needs its far samples.
  bool cell_in_world(int64_t i, int64_t j) const {
    return i >= world_.x0 && j >= world_.y0 && i < world_.x1 - 1 && j < world_.y1 - 1;
  }

 private:
  const TerrainSnapshot& s_;
  RectI world_;
  const CoarseTile* coarse_ = nullptr;
  const DetailTile* detail_ = nullptr;
  int64_t ctx_ = 0, cty_ = 0, dtx_ = 0, dty_ = 0;
  bool coarse_looked_ = false, detail_looked_ = false;
};

struct CellCorners {
  double h00 = 0, h10 = 0, h01 = 0, h11 = 0;
};

std::optional<CellCorners> corners(SampleReader& r, int64_t i, int64_t j) {
  const auto a = r.coarse_m(i, j), b = r.coarse_m(i + 1, j), c = r.coarse_m(i, j + 1),
             d = r.coarse_m(i + 1, j + 1);
  if (!a || !b || !c || !d) return std::nullopt;
  return CellCorners{*a, *b, *c, *d};
}

// The height of a cell's triangle at local (fx, fy) in [0, 1]^2: the (0,0)-(1,1) diagonal
// splits it into {(0,0), (1,0), (1,1)} (fx >= fy) and {(0,0), (1,1), (0,1)}.
double plane_height(const CellCorners& c, double fx, double fy) {
  if (fx >= fy) return c.h00 + fx * (c.h10 - c.h00) + fy * (c.h11 - c.h10);
  return c.h00 + fy * (c.h01 - c.h00) + fx * (c.h11 - c.h01);
}

// d height / d local (fx, fy) of that triangle.
glm::dvec2 plane_slope(const CellCorners& c, double fx, double fy) {
  if (fx >= fy) return {c.h10 - c.h00, c.h11 - c.h10};
  return {c.h11 - c.h01, c.h01 - c.h00};
}

// Splits a coordinate in samples into a cell and its fraction, the last sample of an axis
// belonging to the cell before it.
void cell_of(double u, int64_t last_cell, int64_t& i, double& f) {
  split_coordinate(u, i, f);
  if (i == last_cell + 1 && f == 0.0) {
    i = last_cell;
    f = 1.0;
  }
}

// The triangles of coarse cell (i, j) (two, or two per detail cell where detail is held);
// false when the cell is outside the world or a corner is not held.
bool cell_triangles(SampleReader& r, int64_t i, int64_t j, std::vector<Triangle>& out) {
  out.clear();
  if (!r.cell_in_world(i, j)) return false;
  const auto c = corners(r, i, j);
  if (!c) return false;
  const WorldParams& p = r.snapshot().params();
  const double h = p.meters_per_sample;
  if (!r.cell_has_detail(i, j)) {
    const double x0 = double(i) * h, y0 = double(j) * h, x1 = double(i + 1) * h, y1 = double(j + 1) * h;
    out.push_back({{x0, y0, c->h00}, {x1, y0, c->h10}, {x1, y1, c->h11}});
    out.push_back({{x0, y0, c->h00}, {x1, y1, c->h11}, {x0, y1, c->h01}});
    return true;
  }
  const int64_t f = p.detail_factor;
  const double dm = p.detail_meters_per_sample();
  auto vertex = [&](int64_t a, int64_t b) {
    const int64_t di = i * f + a, dj = j * f + b;
    return glm::dvec3{double(di) * dm, double(dj) * dm,
                      plane_height(*c, double(a) / double(f), double(b) / double(f)) + r.detail_m(di, dj)};
  };
  for (int64_t b = 0; b < f; ++b) {
    for (int64_t a = 0; a < f; ++a) {
      const glm::dvec3 v00 = vertex(a, b), v10 = vertex(a + 1, b), v01 = vertex(a, b + 1),
                       v11 = vertex(a + 1, b + 1);
      out.push_back({v00, v10, v11});
      out.push_back({v00, v11, v01});
    }
  }
  return true;
}

// The height range of the cells of block (bx, by) (16 x 16 cells, global block grid), from
// the block's samples and those of its right and lower neighbours (the cells' far edges);
// nullopt when the block's own tile is not held.
std::optional<std::pair<double, double>> block_range(const TerrainSnapshot& s, int64_t bx, int64_t by) {
  double lo = kInf, hi = -kInf;
  for (int64_t y = by; y <= by + 1; ++y) {
    for (int64_t x = bx; x <= bx + 1; ++x) {
      const CoarseTile* t = s.coarse_tile(floor_div(x, kBlocksPerTile), floor_div(y, kBlocksPerTile));
      if (t == nullptr) {
        if (x == bx && y == by) return std::nullopt;
        continue;
      }
      const size_t k = size_t(floor_mod(y, kBlocksPerTile) * kBlocksPerTile + floor_mod(x, kBlocksPerTile));
      lo = std::min(lo, s.params().height_meters(t->block_min[k]));
      hi = std::max(hi, s.params().height_meters(t->block_max[k]));
    }
  }
  const double d = s.detail_extent_m();
  return std::make_pair(lo - d, hi + d);
}

// Visits the cells (spacing `size`) crossed by the 2D line o + t * d for t in [t0, t1], in
// order of t; fn(ix, iy, t_enter, t_exit) returns false to stop. Amanatides & Woo.
template <typename Fn>
void walk_grid(double ox, double oy, double dx, double dy, double t0, double t1, double size, Fn&& fn) {
  const double x = ox + t0 * dx, y = oy + t0 * dy;
  int64_t ix = int64_t(std::floor(x / size)), iy = int64_t(std::floor(y / size));
  const int64_t step_x = dx > 0 ? 1 : (dx < 0 ? -1 : 0), step_y = dy > 0 ? 1 : (dy < 0 ? -1 : 0);
  double next_x = dx > 0 ? (double(ix + 1) * size - ox) / dx : dx < 0 ? (double(ix) * size - ox) / dx : kInf;
  double next_y = dy > 0 ? (double(iy + 1) * size - oy) / dy : dy < 0 ? (double(iy) * size - oy) / dy : kInf;
  const double delta_x = dx != 0 ? size / std::fabs(dx) : kInf,
               delta_y = dy != 0 ? size / std::fabs(dy) : kInf;
  double t = t0;
  for (int guard = 0; guard < (1 << 26); ++guard) {
    const double tn = std::min({next_x, next_y, t1});
    if (!fn(ix, iy, t, std::max(t, tn))) return;
    if (tn >= t1) return;
    if (next_x < next_y) {
      ix += step_x;
      next_x += delta_x;
    } else {
      iy += step_y;
      next_y += delta_y;
    }
    t = tn;
  }
}

// Clips the segment o + t * d, t in [t0, t1], to the box [lo, hi] on x and y.
bool clip_xy(const glm::dvec3& o, const glm::dvec3& d, double lox, double loy, double hix, double hiy,
             double& t0, double& t1) {
  const double los[2] = {lox, loy}, his[2] = {hix, hiy}, os[2] = {o.x, o.y}, ds[2] = {d.x, d.y};
  for (int a = 0; a < 2; ++a) {
    if (ds[a] == 0.0) {
      if (os[a] < los[a] || os[a] > his[a]) return false;
      continue;
    }
    double ta = (los[a] - os[a]) / ds[a], tb = (his[a] - os[a]) / ds[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 <= t1;
}

// When a box of half extents `half` centred at `mid`, moved by t * motion (t in [0, 1]), first
// overlaps the box [lo, hi]; nullopt when it never does.
std::optional<double> moving_box_entry(const glm::dvec3& mid, const glm::dvec3& half,
                                       const glm::dvec3& motion, const glm::dvec3& lo, const glm::dvec3& hi) {
  double t0 = 0.0, t1 = 1.0;
  for (int a = 0; a < 3; ++a) {
    const double blo = lo[a] - half[a], bhi = hi[a] + half[a];
    if (motion[a] == 0.0) {
      if (mid[a] < blo || mid[a] > bhi) return std::nullopt;
      continue;
    }
    double ta = (blo - mid[a]) / motion[a], tb = (bhi - mid[a]) / motion[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return std::nullopt;
  }
  return t0;
}

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

namespace {

// The two triangles under a point: the coarse cell's corners and the point's fraction in it,
// and the same on the detail grid (zeros where no detail is held).
struct PointCells {
  CellCorners coarse, detail;
  double fx = 0, fy = 0, dfx = 0, dfy = 0;
};

std::optional<PointCells> locate(const TerrainSnapshot& s, double x, double y) {
  if (!std::isfinite(x) || !std::isfinite(y)) return std::nullopt;
  SampleReader r(s);
  const WorldParams& p = s.params();
  PointCells out;
  int64_t i, j;
  cell_of(x / p.meters_per_sample, r.world().x1 - 2, i, out.fx);
  cell_of(y / p.meters_per_sample, r.world().y1 - 2, j, out.fy);
  if (!r.cell_in_world(i, j)) return std::nullopt;
  const auto c = corners(r, i, j);
  if (!c) return std::nullopt;
  out.coarse = *c;
  if (s.detail_tiles() != 0) {
    const double dm = p.detail_meters_per_sample();
    int64_t di, dj;
    split_coordinate(x / dm, di, out.dfx);
    split_coordinate(y / dm, dj, out.dfy);
    out.detail = {r.detail_m(di, dj), r.detail_m(di + 1, dj), r.detail_m(di, dj + 1),
                  r.detail_m(di + 1, dj + 1)};
  }
  return out;
}

}  // namespace

std::optional<double> height_at(const TerrainSnapshot& s, double x, double y) {
  const auto c = locate(s, x, y);
  if (!c) return std::nullopt;
  return plane_height(c->coarse, c->fx, c->fy) + plane_height(c->detail, c->dfx, c->dfy);
}

std::optional<glm::dvec3> normal_at(const TerrainSnapshot& s, double x, double y) {
  const auto c = locate(s, x, y);
  if (!c) return std::nullopt;
  const glm::dvec2 g = plane_slope(c->coarse, c->fx, c->fy) / s.params().meters_per_sample +
                       plane_slope(c->detail, c->dfx, c->dfy) / s.params().detail_meters_per_sample();
  return glm::normalize(glm::dvec3{-g.x, -g.y, 1.0});
}

RayResult raycast(const TerrainSnapshot& s, const glm::dvec3& origin, const glm::dvec3& direction,
                  double max_distance) {
  return raycast(s, origin, direction, max_distance, nullptr);
}

RayResult raycast(const TerrainSnapshot& s, const glm::dvec3& origin, const glm::dvec3& direction,
                  double max_distance, QueryWork* work) {
  RayResult out;
  const double len = glm::length(direction);
  if (!finite(origin) || !(len > 0.0) || !std::isfinite(len) || !(max_distance >= 0.0)) return out;
  const glm::dvec3 d = direction / len;
  const WorldParams& p = s.params();
  const double h = p.meters_per_sample;
  const RectI& w = s.world_samples();
  double t0 = 0.0, t1 = std::min(max_distance, 1e12);
  if (!clip_xy(origin, d, double(w.x0) * h, double(w.y0) * h, double(w.x1 - 1) * h, double(w.y1 - 1) * h, t0,
               t1)) {
    return out;
  }
  SampleReader r(s);
  std::vector<Triangle> tris;
  const double block = h * kBlockSamples;
  walk_grid(origin.x, origin.y, d.x, d.y, t0, t1, block, [&](int64_t bx, int64_t by, double ta, double tb) {
    const auto range = block_range(s, bx, by);
    if (!range) {
      out.reached_unheld = true;
      return true;
    }
    const double za = origin.z + ta * d.z, zb = origin.z + tb * d.z;
    if (std::min(za, zb) > range->second || std::max(za, zb) < range->first) {
      if (work) ++work->blocks_skipped;
      return true;
    }
    if (work) ++work->blocks_visited;
    bool found = false;
    walk_grid(origin.x, origin.y, d.x, d.y, ta, tb, h, [&](int64_t ci, int64_t cj, double, double) {
      // The last sample row and column belong to the cells before them.
      ci = std::min(ci, w.x1 - 2);
      cj = std::min(cj, w.y1 - 2);
      if (!cell_triangles(r, ci, cj, tris)) {
        if (r.cell_in_world(ci, cj)) out.reached_unheld = true;
        return true;
      }
      for (const Triangle& tri : tris) {
        if (work) ++work->triangles_tested;
        const double limit = out.hit ? out.hit->distance : t1;
        if (const auto t = ray_triangle(origin, d, tri, limit)) {
          out.hit = RayHit{*t, origin + d * *t, upward_normal(tri)};
        }
      }
      // Cells come in order along the ray: the first with a hit holds the nearest.
      found = out.hit.has_value();
      return !found;
    });
    return !found;
  });
  return out;
}

SweepResult sweep_sphere(const TerrainSnapshot& s, const glm::dvec3& center, double radius,
                         const glm::dvec3& motion) {
  return sweep_capsule(s, Capsule{center, center, radius}, motion, nullptr);
}

SweepResult sweep_capsule(const TerrainSnapshot& s, const Capsule& capsule, const glm::dvec3& motion) {
  return sweep_capsule(s, capsule, motion, nullptr);
}

SweepResult sweep_capsule(const TerrainSnapshot& s, const Capsule& capsule, const glm::dvec3& motion,
                          QueryWork* work) {
  SweepResult out;
  if (!finite(capsule.p) || !finite(capsule.q) || !finite(motion) || !(capsule.radius >= 0.0) ||
      !std::isfinite(capsule.radius)) {
    return out;
  }
  const WorldParams& p = s.params();
  const double h = p.meters_per_sample;
  const RectI& w = s.world_samples();
  // The shape's box at the start, and the box it sweeps.
  const glm::dvec3 slo = glm::min(capsule.p, capsule.q) - capsule.radius;
  const glm::dvec3 shi = glm::max(capsule.p, capsule.q) + capsule.radius;
  const glm::dvec3 lo = glm::min(slo, slo + motion), hi = glm::max(shi, shi + motion);
  const int64_t i0 = std::max<int64_t>(w.x0, int64_t(std::floor(lo.x / h)));
  const int64_t i1 = std::min<int64_t>(w.x1 - 2, int64_t(std::floor(hi.x / h)));
  const int64_t j0 = std::max<int64_t>(w.y0, int64_t(std::floor(lo.y / h)));
  const int64_t j1 = std::min<int64_t>(w.y1 - 2, int64_t(std::floor(hi.y / h)));
  if (i0 > i1 || j0 > j1) return out;

  // Blocks the swept box meets, in the order the moving shape's box could first reach them.
  struct Candidate {
    double entry;
    int64_t bx, by;
  };
  std::vector<Candidate> candidates;
  const glm::dvec3 half = (shi - slo) * 0.5, mid = (shi + slo) * 0.5;
  for (int64_t by = floor_div(j0, kBlockSamples); by <= floor_div(j1, kBlockSamples); ++by) {
    for (int64_t bx = floor_div(i0, kBlockSamples); bx <= floor_div(i1, kBlockSamples); ++bx) {
      const auto range = block_range(s, bx, by);
      if (!range) {
        out.reached_unheld = true;
        continue;
      }
      if (range->second < lo.z || range->first > hi.z) {
        if (work) ++work->blocks_skipped;
        continue;
      }
      // The block's box against the path of the shape's box.
      const auto entry = moving_box_entry(
          mid, half, motion, {double(bx * kBlockSamples) * h, double(by * kBlockSamples) * h, range->first},
          {double((bx + 1) * kBlockSamples) * h, double((by + 1) * kBlockSamples) * h, range->second});
      if (!entry) {
        if (work) ++work->blocks_skipped;
        continue;
      }
      candidates.push_back({*entry, bx, by});
    }
  }
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.entry < b.entry; });

  SampleReader r(s);
  std::vector<Triangle> tris;
  for (const Candidate& c : candidates) {
    if (out.contact && c.entry > out.contact->t) break;
    if (work) ++work->blocks_visited;
    const int64_t ci0 = std::max(i0, c.bx * kBlockSamples),
                  ci1 = std::min(i1, c.bx * kBlockSamples + kBlockSamples - 1);
    const int64_t cj0 = std::max(j0, c.by * kBlockSamples),
                  cj1 = std::min(j1, c.by * kBlockSamples + kBlockSamples - 1);
    for (int64_t cj = cj0; cj <= cj1; ++cj) {
      for (int64_t ci = ci0; ci <= ci1; ++ci) {
        // The cell's box against the shape's path: a long sweep visits the cells along it only.
        const auto c4 = corners(r, ci, cj);
        if (!c4) {
          out.reached_unheld = true;
          continue;
        }
        const double d = s.detail_extent_m();
        const auto entry = moving_box_entry(
            mid, half, motion,
            {double(ci) * h, double(cj) * h, std::min({c4->h00, c4->h10, c4->h01, c4->h11}) - d},
            {double(ci + 1) * h, double(cj + 1) * h, std::max({c4->h00, c4->h10, c4->h01, c4->h11}) + d});
        if (!entry || (out.contact && *entry > out.contact->t)) continue;
        if (!cell_triangles(r, ci, cj, tris)) {
          out.reached_unheld = true;
          continue;
        }
        for (const Triangle& tri : tris) {
          const glm::dvec3 tlo = glm::min(tri.a, glm::min(tri.b, tri.c)),
                           thi = glm::max(tri.a, glm::max(tri.b, tri.c));
          if (tlo.x > hi.x || tlo.y > hi.y || tlo.z > hi.z || thi.x < lo.x || thi.y < lo.y || thi.z < lo.z)
            continue;
          if (work) ++work->triangles_tested;
          const auto contact = sweep_capsule_triangle(capsule, motion, tri);
          if (contact && (!out.contact || contact->t < out.contact->t)) out.contact = contact;
        }
      }
    }
  }
  return out;
}

}  // namespace loam::query
