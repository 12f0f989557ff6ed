#include "client/lod/geomipmap.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>

namespace loam::lod {

uint16_t HeightGrid::at(int64_t x, int64_t y) const {
  x = std::clamp<int64_t>(x, 0, width - 1);
  y = std::clamp<int64_t>(y, 0, height - 1);
  return samples[size_t(y * width + x)];
}

Result<GeomipmapGrid> GeomipmapGrid::make(int64_t width, int64_t height, int32_t patch_size) {
  const int32_t c = patch_size - 1;
  // Local vertex indices are 16-bit: 129^2 vertices at most.
  if (c < 4 || c > 128 || !std::has_single_bit(uint32_t(c))) {
    return make_error(
        ErrorCode::kInvalidArgument, "geomipmap.patch_size",
        "must be 2^k + 1 with 2 <= k <= 7 (5, 9, 17, 33, 65 or 129), got " + std::to_string(patch_size));
  }
  if (width < 2 || height < 2)
    return make_error(ErrorCode::kInvalidArgument, "geomipmap.world", "needs at least 2 x 2 samples");
  GeomipmapGrid g;
  g.patch_size = patch_size;
  g.levels = std::countr_zero(uint32_t(c)) + 1;
  g.width = width;
  g.height = height;
  g.patches_x = int32_t((width - 1 + c - 1) / c);
  g.patches_y = int32_t((height - 1 + c - 1) / c);
  return g;
}

RectI GeomipmapGrid::patch_rect(int32_t px, int32_t py) const {
  const int64_t c = cells();
  return {px * c, py * c, px * c + c + 1, py * c + c + 1};
}

RectI GeomipmapGrid::covered() const {
  return {0, 0, int64_t(patches_x) * cells() + 1, int64_t(patches_y) * cells() + 1};
}

namespace {

bool main_diagonal(int32_t x, int32_t y, int32_t s) { return union_jack_main_diagonal(x, y, s); }

// The level-l surface (cells of side s, union-jack split) at local sample (lx, ly) of the patch
// at (x0, y0), from the true heights at its vertices.
double level_surface(const HeightGrid& h, int64_t x0, int64_t y0, int32_t c, int32_t s, int32_t lx,
                     int32_t ly) {
  const int32_t qx = std::min(lx / s * s, c - s), qy = std::min(ly / s * s, c - s);
  double fx = double(lx - qx) / s, fy = double(ly - qy) / s;
  double h00 = h.at(x0 + qx, y0 + qy), h10 = h.at(x0 + qx + s, y0 + qy);
  double h01 = h.at(x0 + qx, y0 + qy + s), h11 = h.at(x0 + qx + s, y0 + qy + s);
  return union_jack_surface(h00, h10, h01, h11, fx, fy, main_diagonal(qx, qy, s));
}

}  // namespace

void GeomipmapErrors::compute_patch(const GeomipmapGrid& grid, const HeightGrid& heights, int32_t px,
                                    int32_t py) {
  const int32_t c = grid.cells();
  const int64_t x0 = int64_t(px) * c, y0 = int64_t(py) * c;
  uint16_t lo = 65535, hi = 0;
  for (int32_t ly = 0; ly <= c; ++ly) {
    for (int32_t lx = 0; lx <= c; ++lx) {
      const uint16_t v = heights.at(x0 + lx, y0 + ly);
      lo = std::min(lo, v), hi = std::max(hi, v);
    }
  }
  bounds_[index(px, py)] = {lo, hi};
  float* e = &errors_[index(px, py) * size_t(levels_)];
  e[0] = 0;
  for (int32_t l = 1; l < levels_; ++l) {
    const int32_t s = 1 << l;
    double worst = 0;
    for (int32_t ly = 0; ly <= c; ++ly) {
      for (int32_t lx = 0; lx <= c; ++lx) {
        if (lx % s == 0 && ly % s == 0) continue;  // a vertex of the level: exact
        const double d =
            std::abs(double(heights.at(x0 + lx, y0 + ly)) - level_surface(heights, x0, y0, c, s, lx, ly));
        worst = std::max(worst, d);
      }
    }
    // Rounded up so that the bound holds in float.
    e[l] = std::max(e[l - 1], std::nextafter(float(worst), INFINITY));
    if (worst == 0) e[l] = e[l - 1];
  }
}

GeomipmapErrors GeomipmapErrors::compute(const GeomipmapGrid& grid, const HeightGrid& heights) {
  GeomipmapErrors e;
  e.patches_x_ = grid.patches_x;
  e.levels_ = grid.levels;
  e.errors_.assign(size_t(grid.patch_count()) * size_t(grid.levels), 0.0f);
  e.bounds_.assign(size_t(grid.patch_count()), {0, 0});
  for (int32_t py = 0; py < grid.patches_y; ++py)
    for (int32_t px = 0; px < grid.patches_x; ++px) e.compute_patch(grid, heights, px, py);
  return e;
}

std::vector<std::array<int32_t, 2>> GeomipmapErrors::update(const GeomipmapGrid& grid,
                                                            const HeightGrid& heights, const RectI& changed) {
  std::vector<std::array<int32_t, 2>> out;
  if (changed.empty()) return out;
  const int64_t c = grid.cells();
  // Patch p holds samples [p c, p c + c]: a sample x lies in patches (x - c) / c .. x / c.
  const int64_t px0 = std::max<int64_t>(0, ceil_div(changed.x0 - c, c)),
                px1 = std::min<int64_t>(grid.patches_x - 1, floor_div(changed.x1 - 1, c));
  const int64_t py0 = std::max<int64_t>(0, ceil_div(changed.y0 - c, c)),
                py1 = std::min<int64_t>(grid.patches_y - 1, floor_div(changed.y1 - 1, c));
  for (int64_t py = py0; py <= py1; ++py) {
    for (int64_t px = px0; px <= px1; ++px) {
      compute_patch(grid, heights, int32_t(px), int32_t(py));
      out.push_back({int32_t(px), int32_t(py)});
    }
  }
  return out;
}

double union_jack_surface(double h00, double h10, double h01, double h11, double fx, double fy,
                          bool main_diagonal) {
  if (!main_diagonal) {
    // Mirror x: the split (s, 0)-(0, s) becomes (0, 0)-(s, s).
    std::swap(h00, h10);
    std::swap(h01, h11);
    fx = 1.0 - fx;
  }
  if (fx >= fy) return h00 + (h10 - h00) * fx + (h11 - h10) * fy;
  return h00 + (h01 - h00) * fy + (h11 - h01) * fx;
}

double box_distance(double x, double y, double z, const std::array<double, 3>& lo,
                    const std::array<double, 3>& hi) {
  const double dx = std::max({lo[0] - x, 0.0, x - hi[0]});
  const double dy = std::max({lo[1] - y, 0.0, y - hi[1]});
  const double dz = std::max({lo[2] - z, 0.0, z - hi[2]});
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

void rasterize_heights(const std::array<int64_t, 3>& x, const std::array<int64_t, 3>& y,
                       const std::array<double, 3>& z, const RectI& cov, std::vector<float>& out) {
  const int64_t area2 = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
  if (area2 == 0) return;
  const int64_t bx0 = std::max(cov.x0, std::min({x[0], x[1], x[2]})),
                bx1 = std::min(cov.x1 - 1, std::max({x[0], x[1], x[2]}));
  const int64_t by0 = std::max(cov.y0, std::min({y[0], y[1], y[2]})),
                by1 = std::min(cov.y1 - 1, std::max({y[0], y[1], y[2]}));
  const int64_t sign = area2 > 0 ? 1 : -1;
  for (int64_t sy = by0; sy <= by1; ++sy) {
    for (int64_t sx = bx0; sx <= bx1; ++sx) {
      // Barycentric weights from integer edge functions: inside (edges included) when all >= 0.
      const int64_t w0 = sign * ((x[2] - x[1]) * (sy - y[1]) - (y[2] - y[1]) * (sx - x[1]));
      const int64_t w1 = sign * ((x[0] - x[2]) * (sy - y[2]) - (y[0] - y[2]) * (sx - x[2]));
      const int64_t w2 = sign * area2 - w0 - w1;
      if (w0 < 0 || w1 < 0 || w2 < 0) continue;
      const double v = (double(w0) * z[0] + double(w1) * z[1] + double(w2) * z[2]) / double(sign * area2);
      out[size_t((sy - cov.y0) * cov.width() + (sx - cov.x0))] = float(v);
    }
  }
}

double pixels_per_radian(int32_t viewport_height, double fov_y_degrees) {
  return double(viewport_height) / (2.0 * std::tan(fov_y_degrees * M_PI / 360.0));
}

void assign_sides(const GeomipmapGrid& grid, std::vector<PatchLod>& lods) {
  // The coarser level of the two patches, and the largest morph among those at it.
  for (int32_t py = 0; py < grid.patches_y; ++py) {
    for (int32_t px = 0; px < grid.patches_x; ++px) {
      PatchLod& p = lods[size_t(py) * size_t(grid.patches_x) + size_t(px)];
      constexpr std::array<std::array<int32_t, 2>, 4> kStep = {{{0, -1}, {1, 0}, {0, 1}, {-1, 0}}};
      for (int32_t side = 0; side < 4; ++side) {
        const int32_t nx = px + kStep[size_t(side)][0], ny = py + kStep[size_t(side)][1];
        p.edge_level[size_t(side)] = p.level;
        p.edge_morph[size_t(side)] = p.morph;
        if (nx < 0 || ny < 0 || nx >= grid.patches_x || ny >= grid.patches_y) continue;
        const PatchLod& n = lods[size_t(ny) * size_t(grid.patches_x) + size_t(nx)];
        if (n.level > p.level) {
          p.edge_level[size_t(side)] = n.level;
          p.edge_morph[size_t(side)] = n.morph;
        } else if (n.level == p.level) {
          p.edge_morph[size_t(side)] = std::max(p.morph, n.morph);
        }
      }
    }
  }
}

void assign_own_sides(std::vector<PatchLod>& lods) {
  for (PatchLod& p : lods) {
    p.edge_level.fill(p.level);
    p.edge_morph.fill(p.morph);
  }
}

std::vector<float> skirt_depths(const GeomipmapGrid& grid, const GeomipmapErrors& errors,
                                const std::vector<PatchLod>& lods) {
  auto drawn_error = [&](int32_t px, int32_t py) {
    const PatchLod& p = lods[size_t(py) * size_t(grid.patches_x) + size_t(px)];
    const int32_t l = p.morph > 0 ? std::min(p.level + 1, grid.levels - 1) : p.level;
    return errors.error(px, py, l);
  };
  std::vector<float> out(lods.size(), 0.0f);
  constexpr std::array<std::array<int32_t, 2>, 4> kStep = {{{0, -1}, {1, 0}, {0, 1}, {-1, 0}}};
  for (int32_t py = 0; py < grid.patches_y; ++py) {
    for (int32_t px = 0; px < grid.patches_x; ++px) {
      float depth = 0;
      for (const auto& d : kStep) {
        const int32_t nx = px + d[0], ny = py + d[1];
        if (nx < 0 || ny < 0 || nx >= grid.patches_x || ny >= grid.patches_y) continue;
        depth = std::max(depth, drawn_error(px, py) + drawn_error(nx, ny));
      }
      // Rounded up a unit: the renderer takes whole height units.
      out[size_t(py) * size_t(grid.patches_x) + size_t(px)] = depth > 0 ? std::ceil(depth) + 1.0f : 0.0f;
    }
  }
  return out;
}

std::vector<float> side_profile(const GeomipmapGrid& grid, const HeightGrid& heights, int32_t px, int32_t py,
                                const PatchLod& lod, int32_t side) {
  const int32_t c = grid.cells(), e = lod.edge_level[size_t(side)], se = 1 << e;
  auto at = [&](int32_t t) -> std::array<int32_t, 2> {
    switch (side) {
      case kSideTop: return {t, 0};
      case kSideRight: return {c, t};
      case kSideBottom: return {t, c};
      default: return {0, t};
    }
  };
  std::vector<float> out(size_t(c) + 1);
  for (int32_t t0 = 0; t0 < c; t0 += se) {
    const auto a = at(t0), b = at(t0 + se);
    const double ha = displayed_height(grid, heights, px, py, lod, a[0], a[1]);
    const double hb = displayed_height(grid, heights, px, py, lod, b[0], b[1]);
    for (int32_t t = t0; t <= t0 + se; ++t)
      out[size_t(t)] = float(ha + (hb - ha) * double(t - t0) / double(se));
  }
  return out;
}

std::vector<PatchLod> select_lods(const GeomipmapGrid& grid, const GeomipmapErrors& errors,
                                  const HeightScale& scale, const LodView& view, bool morph) {
  std::vector<PatchLod> lods(size_t(grid.patch_count()));
  const double mps = scale.meters_per_sample;
  for (int32_t py = 0; py < grid.patches_y; ++py) {
    for (int32_t px = 0; px < grid.patches_x; ++px) {
      const RectI r = grid.patch_rect(px, py);
      const std::array<double, 3> lo{double(r.x0) * mps, double(r.y0) * mps,
                                     scale.meters(errors.min_height(px, py))};
      const std::array<double, 3> hi{double(r.x1 - 1) * mps, double(r.y1 - 1) * mps,
                                     scale.meters(errors.max_height(px, py))};
      const double d = box_distance(view.x, view.y, view.z, lo, hi);
      // The vertical error (m) the budget allows at that distance.
      const double allowed = view.tolerance_px * d / view.pixels_per_radian;
      auto delta = [&](int32_t l) { return double(errors.error(px, py, l)) * scale.meters_per_unit; };
      int32_t l = 0;
      while (l + 1 < grid.levels && delta(l + 1) <= allowed) ++l;
      PatchLod& p = lods[size_t(py) * size_t(grid.patches_x) + size_t(px)];
      p.level = int8_t(l);
      if (morph && l + 1 < grid.levels) {
        p.morph = float(std::clamp((allowed - delta(l)) / (delta(l + 1) - delta(l)), 0.0, 1.0));
      }
    }
  }
  assign_sides(grid, lods);
  return lods;
}

namespace {

using Tri = std::array<uint16_t, 3>;

struct PatchBuilder {
  int32_t n;  // patch_size
  std::vector<Tri> tris;
  uint16_t id(int32_t x, int32_t y) const { return uint16_t(y * n + x); }
  // Adds (a, b, c) counter-clockwise in (x, y) (positive area, y along +gy).
  void add(std::array<int32_t, 2> a, std::array<int32_t, 2> b, std::array<int32_t, 2> c) {
    const int64_t area2 = int64_t(b[0] - a[0]) * (c[1] - a[1]) - int64_t(c[0] - a[0]) * (b[1] - a[1]);
    if (area2 < 0) std::swap(b, c);
    tris.push_back({id(a[0], a[1]), id(b[0], b[1]), id(c[0], c[1])});
  }
};

}  // namespace

std::vector<std::array<uint16_t, 3>> skirt_triangles(const GeomipmapGrid& grid, int32_t level) {
  const int32_t n = grid.patch_size, c = grid.cells(), s = 1 << level;
  std::vector<std::array<uint16_t, 3>> out;
  auto top = [&](int32_t side, int32_t t) {
    switch (side) {
      case kSideTop: return uint16_t(t);
      case kSideRight: return uint16_t(t * n + c);
      case kSideBottom: return uint16_t(c * n + t);
      default: return uint16_t(t * n);
    }
  };
  auto low = [&](int32_t side, int32_t t) { return uint16_t(n * n + side * n + t); };
  for (int32_t side = 0; side < 4; ++side) {
    for (int32_t t = 0; t < c; t += s) {
      out.push_back({top(side, t), top(side, t + s), low(side, t + s)});
      out.push_back({top(side, t), low(side, t + s), low(side, t)});
    }
  }
  return out;
}

std::vector<std::array<uint16_t, 3>> patch_triangles(const GeomipmapGrid& grid, int32_t level,
                                                     const std::array<int8_t, 4>& edge_level) {
  const int32_t c = grid.cells(), s = 1 << level, cells = c / s;
  PatchBuilder b{grid.patch_size, {}};
  if (cells == 1) {
    b.add({0, 0}, {c, 0}, {c, c});
    b.add({0, 0}, {c, c}, {0, c});
    return b.tris;
  }
  auto coarse = [&](int32_t side) { return edge_level[size_t(side)] > level; };
  // Side frames: position t along the side, depth d in from it.
  auto at = [&](int32_t side, int32_t t, int32_t d) -> std::array<int32_t, 2> {
    switch (side) {
      case kSideTop: return {t, d};
      case kSideRight: return {c - d, t};
      case kSideBottom: return {t, c - d};
      default: return {d, t};
    }
  };
  // Cells: union-jack quads, except those along a side whose neighbour is coarser, which
  // that side's strip covers (a corner cell only its half, split along the corner's diagonal,
  // which is its union-jack diagonal too).
  for (int32_t j = 0; j < cells; ++j) {
    for (int32_t i = 0; i < cells; ++i) {
      const int32_t x = i * s, y = j * s;
      const bool top = j == 0 && coarse(kSideTop), bottom = j == cells - 1 && coarse(kSideBottom);
      const bool left = i == 0 && coarse(kSideLeft), right = i == cells - 1 && coarse(kSideRight);
      const bool corner = (i == 0 || i == cells - 1) && (j == 0 || j == cells - 1);
      if (!top && !bottom && !left && !right) {
        if (main_diagonal(x, y, s)) {
          b.add({x, y}, {x + s, y}, {x + s, y + s});
          b.add({x, y}, {x + s, y + s}, {x, y + s});
        } else {
          b.add({x + s, y}, {x + s, y + s}, {x, y + s});
          b.add({x + s, y}, {x, y + s}, {x, y});
        }
        continue;
      }
      if (!corner) continue;
      // A corner cell with one coarse side: the other side's half.
      const bool at_left = i == 0, at_top = j == 0;
      const std::array<int32_t, 2> k{at_left ? 0 : c, at_top ? 0 : c};
      const std::array<int32_t, 2> in{at_left ? s : c - s, at_top ? s : c - s};
      if (!(top || bottom)) b.add(k, in, {in[0], k[1]});
      if (!(left || right)) b.add(k, in, {k[0], in[1]});
    }
  }
  for (int32_t side = 0; side < 4; ++side) {
    if (!coarse(side)) continue;
    const int32_t e = edge_level[size_t(side)], se = 1 << e;
    if (e == level + 1) {
      // The union-jack strip without the side's odd vertices: each pair of cells becomes a
      // triangle fan around the pair's inner midpoint, the very triangles of the strip once
      // those vertices lie on the coarser edge (a neighbour's level change moves nothing).
      for (int32_t t = 0; t < c; t += 2 * s) {
        b.add(at(side, t, 0), at(side, t + 2 * s, 0), at(side, t + s, s));
        if (t > 0) b.add(at(side, t, 0), at(side, t + s, s), at(side, t, s));
        if (t + 2 * s < c) b.add(at(side, t + 2 * s, 0), at(side, t + 2 * s, s), at(side, t + s, s));
      }
      continue;
    }
    // Two or more levels coarser: zip the side's vertices to the inner line in order.
    int32_t to = 0, ti = s;  // positions along the side of the current outer and inner vertex
    while (to < c || ti < c - s) {
      const bool advance_outer = ti >= c - s || (to < c && to + se <= ti + s);
      if (advance_outer) {
        b.add(at(side, ti, s), at(side, to, 0), at(side, to + se, 0));
        to += se;
      } else {
        b.add(at(side, ti, s), at(side, to, 0), at(side, ti + s, s));
        ti += s;
      }
    }
  }
  return b.tris;
}

float morphed_vertex_height(int32_t c, int32_t levels, const PatchLod& lod, int32_t lx, int32_t ly,
                            const std::function<double(int32_t, int32_t)>& h) {
  const double own = h(lx, ly);
  const bool on_x = lx == 0 || lx == c, on_y = ly == 0 || ly == c;
  if (on_x && on_y) return float(own);  // a corner: a vertex of every level
  if (on_x || on_y) {
    const int32_t side = ly == 0 ? kSideTop : lx == c ? kSideRight : ly == c ? kSideBottom : kSideLeft;
    const int32_t e = lod.edge_level[size_t(side)];
    const float m = lod.edge_morph[size_t(side)];
    const int32_t se = 1 << e, t = on_y ? lx : ly;
    if (m == 0 || e + 1 >= levels || t % (2 * se) == 0) return float(own);
    const double target =
        on_y ? 0.5 * (h(lx - se, ly) + h(lx + se, ly)) : 0.5 * (h(lx, ly - se) + h(lx, ly + se));
    return float(own + double(m) * (target - own));
  }
  const int32_t s = 1 << lod.level;
  if (lod.morph == 0 || lod.level + 1 >= levels) return float(own);
  const int32_t ox = (lx / s) & 1, oy = (ly / s) & 1;
  if (ox == 0 && oy == 0) return float(own);
  double target;
  if (ox == 0 || oy == 0) {  // the midpoint of a coarser cell's edge
    target = 0.5 * (h(lx - ox * s, ly - oy * s) + h(lx + ox * s, ly + oy * s));
  } else if (main_diagonal(lx - s, ly - s, 2 * s)) {  // a coarser cell's centre, on its diagonal
    target = 0.5 * (h(lx - s, ly - s) + h(lx + s, ly + s));
  } else {
    target = 0.5 * (h(lx + s, ly - s) + h(lx - s, ly + s));
  }
  return float(own + double(lod.morph) * (target - own));
}

float displayed_height(const GeomipmapGrid& grid, const HeightGrid& heights, int32_t px, int32_t py,
                       const PatchLod& lod, int32_t lx, int32_t ly) {
  const int32_t c = grid.cells();
  // One captured reference: the callable fits std::function's inline storage (no allocation
  // per vertex, which the replicas' displayed_surface asks for millions of times).
  const struct {
    const HeightGrid& heights;
    int64_t x0, y0;
  } patch{heights, int64_t(px) * c, int64_t(py) * c};
  return morphed_vertex_height(c, grid.levels, lod, lx, ly, [&patch](int32_t x, int32_t y) {
    return double(patch.heights.at(patch.x0 + x, patch.y0 + y));
  });
}

namespace {

// The triangles of every patch, each set built once per (level, edge levels).
template <typename Fn>
void for_each_patch_triangles(const GeomipmapGrid& grid, const std::vector<PatchLod>& lods, const Fn& fn) {
  std::map<std::array<int8_t, 5>, std::vector<Tri>> cache;
  for (int32_t py = 0; py < grid.patches_y; ++py) {
    for (int32_t px = 0; px < grid.patches_x; ++px) {
      const PatchLod& lod = lods[size_t(py) * size_t(grid.patches_x) + size_t(px)];
      const std::array<int8_t, 5> key{lod.level, lod.edge_level[0], lod.edge_level[1], lod.edge_level[2],
                                      lod.edge_level[3]};
      auto it = cache.find(key);
      if (it == cache.end()) it = cache.emplace(key, patch_triangles(grid, lod.level, lod.edge_level)).first;
      fn(px, py, lod, it->second);
    }
  }
}

}  // namespace

std::vector<lod::ReplicaTriangle> replicate(const GeomipmapGrid& grid, const std::vector<PatchLod>& lods) {
  std::vector<lod::ReplicaTriangle> out;
  const int32_t n = grid.patch_size, c = grid.cells();
  for_each_patch_triangles(grid, lods,
                           [&](int32_t px, int32_t py, const PatchLod&, const std::vector<Tri>& tris) {
                             for (const Tri& t : tris) {
                               lod::ReplicaTriangle r;
                               for (size_t k = 0; k < 3; ++k) {
                                 r.x[k] = int64_t(px) * c + t[k] % n;
                                 r.y[k] = int64_t(py) * c + t[k] / n;
                               }
                               out.push_back(r);
                             }
                           });
  return out;
}

std::vector<float> displayed_surface(const GeomipmapGrid& grid, const HeightGrid& heights,
                                     const std::vector<PatchLod>& lods) {
  const RectI cov = grid.covered();
  std::vector<float> out(size_t(cov.area()), 0.0f);
  const int32_t n = grid.patch_size, c = grid.cells();
  for_each_patch_triangles(
      grid, lods, [&](int32_t px, int32_t py, const PatchLod& lod, const std::vector<Tri>& tris) {
        for (const Tri& t : tris) {
          std::array<int64_t, 3> x{}, y{};
          std::array<double, 3> z{};
          for (size_t k = 0; k < 3; ++k) {
            x[k] = t[k] % n, y[k] = t[k] / n;
            z[k] = displayed_height(grid, heights, px, py, lod, int32_t(x[k]), int32_t(y[k]));
          }
          for (size_t k = 0; k < 3; ++k) x[k] += int64_t(px) * c, y[k] += int64_t(py) * c;
          rasterize_heights(x, y, z, cov, out);
        }
      });
  return out;
}

int64_t triangle_count(const GeomipmapGrid& grid, const std::vector<PatchLod>& lods) {
  int64_t n = 0;
  for_each_patch_triangles(grid, lods, [&](int32_t, int32_t, const PatchLod&, const std::vector<Tri>& tris) {
    n += int64_t(tris.size());
  });
  return n;
}

}  // namespace loam::lod
