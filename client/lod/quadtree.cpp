#include "client/lod/quadtree.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <functional>

namespace loam::lod {

namespace {

constexpr double kSqrt3 = 1.7320508075688772;

int32_t ctz_or(int64_t v, int32_t none) { return v == 0 ? none : std::countr_zero(uint64_t(v)); }

// Calls fn(x, y) for every integer point of triangle (a, b, c), its edges included.
template <typename Fn>
void for_each_point(std::array<int64_t, 2> a, std::array<int64_t, 2> b, std::array<int64_t, 2> c,
                    const Fn& fn) {
  const int64_t area2 = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
  if (area2 == 0) return;
  const int64_t sgn = area2 > 0 ? 1 : -1;
  const int64_t x0 = std::min({a[0], b[0], c[0]}), x1 = std::max({a[0], b[0], c[0]});
  const int64_t y0 = std::min({a[1], b[1], c[1]}), y1 = std::max({a[1], b[1], c[1]});
  for (int64_t y = y0; y <= y1; ++y) {
    for (int64_t x = x0; x <= x1; ++x) {
      const int64_t w0 = sgn * ((c[0] - b[0]) * (y - b[1]) - (c[1] - b[1]) * (x - b[0]));
      const int64_t w1 = sgn * ((a[0] - c[0]) * (y - c[1]) - (a[1] - c[1]) * (x - c[0]));
      const int64_t w2 = sgn * area2 - w0 - w1;
      if (w0 < 0 || w1 < 0 || w2 < 0) continue;
      fn(x, y, double(w0) / double(sgn * area2), double(w1) / double(sgn * area2),
         double(w2) / double(sgn * area2));
    }
  }
}

}  // namespace

Result<QuadtreeGrid> QuadtreeGrid::make(int64_t width, int64_t height, int32_t block_size) {
  if (block_size < 4 || block_size > 256 || !std::has_single_bit(uint32_t(block_size))) {
    return make_error(ErrorCode::kInvalidArgument, "quadtree.block_size",
                      "must be a power of two from 4 to 256, got " + std::to_string(block_size));
  }
  if (width < 2 || height < 2)
    return make_error(ErrorCode::kInvalidArgument, "quadtree.world", "needs at least 2 x 2 samples");
  QuadtreeGrid g;
  g.block_size = block_size;
  g.levels = std::countr_zero(uint32_t(block_size));
  g.width = width, g.height = height;
  g.blocks_x = int32_t((width - 1 + block_size - 1) / block_size);
  g.blocks_y = int32_t((height - 1 + block_size - 1) / block_size);
  return g;
}

RectI QuadtreeGrid::covered() const {
  return {0, 0, int64_t(blocks_x) * block_size + 1, int64_t(blocks_y) * block_size + 1};
}

void QuadtreeErrors::compute_square(const QuadtreeGrid&, const HeightGrid& heights, int32_t l, int32_t i,
                                    int32_t j) {
  const int64_t s = int64_t(1) << l, hs = s / 2, x0 = int64_t(i) * s, y0 = int64_t(j) * s;
  Square& q = squares_[size_t(l)][index(l, i, j)];
  uint16_t lo = 65535, hi = 0;
  for (int64_t y = y0; y <= y0 + s; ++y)
    for (int64_t x = x0; x <= x0 + s; ++x) {
      const uint16_t v = heights.at(x, y);
      lo = std::min(lo, v), hi = std::max(hi, v);
    }
  q.lo = lo, q.hi = hi;
  // Per side, the fan's triangle without the side's midpoint and its two halves with it.
  const std::array<int64_t, 2> c{x0 + hs, y0 + hs};
  const std::array<std::array<int64_t, 2>, 4> corner{
      {{x0, y0}, {x0 + s, y0}, {x0 + s, y0 + s}, {x0, y0 + s}}};
  auto h = [&](const std::array<int64_t, 2>& p) { return double(heights.at(p[0], p[1])); };
  double worst = 0;
  auto measure = [&](std::array<int64_t, 2> a, std::array<int64_t, 2> b, std::array<int64_t, 2> d) {
    const double ha = h(a), hb = h(b), hd = h(d);
    for_each_point(a, b, d, [&](int64_t x, int64_t y, double wa, double wb, double wd) {
      worst = std::max(worst, std::abs(double(heights.at(x, y)) - (wa * ha + wb * hb + wd * hd)));
    });
  };
  for (size_t k = 0; k < 4; ++k) {
    const auto& a = corner[k];
    const auto& b = corner[(k + 1) % 4];
    const std::array<int64_t, 2> m{(a[0] + b[0]) / 2, (a[1] + b[1]) / 2};
    measure(c, a, b);
    measure(c, a, m);
    measure(c, m, b);
  }
  q.delta = worst == 0 ? 0.0f : std::nextafter(float(worst), INFINITY);
}

QuadtreeErrors QuadtreeErrors::compute(const QuadtreeGrid& grid, const HeightGrid& heights) {
  QuadtreeErrors e;
  e.row_.assign(size_t(grid.levels + 1), 0);
  e.squares_.resize(size_t(grid.levels + 1));
  for (int32_t l = 1; l <= grid.levels; ++l) {
    e.row_[size_t(l)] = grid.squares_x(l);
    e.squares_[size_t(l)].resize(size_t(grid.squares_x(l)) * size_t(grid.squares_y(l)));
  }
  e.update(grid, heights, grid.covered());
  return e;
}

int64_t QuadtreeErrors::update(const QuadtreeGrid& grid, const HeightGrid& heights, const RectI& changed) {
  int64_t n = 0;
  if (changed.empty()) return n;
  for (int32_t l = 1; l <= grid.levels; ++l) {
    const int64_t s = int64_t(1) << l;
    // Square i holds samples [i s, i s + s]: a sample x lies in squares (x - s) / s .. x / s.
    const int64_t i0 = std::max<int64_t>(0, ceil_div(changed.x0 - s, s));
    const int64_t i1 = std::min<int64_t>(grid.squares_x(l) - 1, floor_div(changed.x1 - 1, s));
    const int64_t j0 = std::max<int64_t>(0, ceil_div(changed.y0 - s, s));
    const int64_t j1 = std::min<int64_t>(grid.squares_y(l) - 1, floor_div(changed.y1 - 1, s));
    for (int64_t j = j0; j <= j1; ++j) {
      for (int64_t i = i0; i <= i1; ++i) {
        compute_square(grid, heights, l, int32_t(i), int32_t(j));
        Square& q = squares_[size_t(l)][index(l, int32_t(i), int32_t(j))];
        q.subtree = q.delta;
        if (l > 1) {
          for (int32_t cj = 0; cj < 2; ++cj)
            for (int32_t ci = 0; ci < 2; ++ci)
              q.subtree = std::max(q.subtree, subtree(l - 1, int32_t(2 * i + ci), int32_t(2 * j + cj)));
        }
        ++n;
      }
    }
  }
  return n;
}

QuadtreeState::QuadtreeState(const QuadtreeGrid& grid) : grid_(grid) {
  morph_.resize(size_t(grid.levels + 1));
  for (int32_t l = 1; l <= grid.levels; ++l)
    morph_[size_t(l)].assign(size_t(grid.squares_x(l)) * size_t(grid.squares_y(l)), -1.0f);
  changed_.assign(size_t(grid.blocks_x) * size_t(grid.blocks_y), 1);
}

bool QuadtreeState::subdivided(int32_t l, int32_t i, int32_t j) const {
  if (l < 1 || l > grid_.levels || i < 0 || j < 0 || i >= grid_.squares_x(l) || j >= grid_.squares_y(l))
    return false;
  return morph_[size_t(l)][index(l, i, j)] >= 0;
}

float QuadtreeState::morph(int32_t l, int32_t i, int32_t j) const {
  return subdivided(l, i, j) ? morph_[size_t(l)][index(l, i, j)] : 0.0f;
}

void QuadtreeState::set(int32_t l, int32_t i, int32_t j, bool on, float morph) {
  float& m = morph_[size_t(l)][index(l, i, j)];
  const float now = on ? morph : -1.0f;
  if (m == now) return;
  m = now;
  const int32_t shift = grid_.levels - l;
  changed_[size_t(j >> shift) * size_t(grid_.blocks_x) + size_t(i >> shift)] = 1;
}

QuadtreeSelectStats select_quadtree(const QuadtreeGrid& grid, const QuadtreeErrors& errors,
                                    const HeightScale& scale, const LodView& view, QuadtreeState& state,
                                    bool morph) {
  QuadtreeSelectStats st;
  const double mps = scale.meters_per_sample, k = view.pixels_per_radian * kSqrt3 * scale.meters_per_unit;
  const double start = morph ? 0.5 * view.tolerance_px : view.tolerance_px;  // subdivided from here
  // Fresh subdivision, then compared with the state's.
  std::vector<std::vector<float>> fresh(size_t(grid.levels + 1));
  for (int32_t l = 1; l <= grid.levels; ++l)
    fresh[size_t(l)].assign(size_t(grid.squares_x(l)) * size_t(grid.squares_y(l)), -1.0f);
  auto idx = [&](int32_t l, int32_t i, int32_t j) {
    return size_t(j) * size_t(grid.squares_x(l)) + size_t(i);
  };
  auto l1_distance = [&](int32_t l, int32_t i, int32_t j) {
    const double s = double(int64_t(1) << l) * mps;
    const double x0 = double(i) * s, y0 = double(j) * s;
    const double z0 = scale.meters(errors.min_height(l, i, j)), z1 = scale.meters(errors.max_height(l, i, j));
    return std::max({x0 - view.x, 0.0, view.x - (x0 + s)}) + std::max({y0 - view.y, 0.0, view.y - (y0 + s)}) +
           std::max({z0 - view.z, 0.0, view.z - z1});
  };
  // The square's own ratio (pixels), and the morph it gives.
  auto ratio = [&](int32_t l, int32_t i, int32_t j, float err) {
    const double d = l1_distance(l, i, j);
    return d <= 0 ? INFINITY : double(err) * k / d;
  };
  auto morph_of = [&](double r) {
    return morph ? float(std::clamp((r - start) / (view.tolerance_px - start), 0.0, 1.0)) : 1.0f;
  };
  std::function<bool(int32_t, int32_t, int32_t)> visit = [&](int32_t l, int32_t i, int32_t j) -> bool {
    ++st.squares_tested;
    if (ratio(l, i, j, errors.subtree(l, i, j)) <= start) return false;  // the box test: the whole subtree
    bool child = false;
    if (l > 1) {
      for (int32_t cj = 0; cj < 2; ++cj)
        for (int32_t ci = 0; ci < 2; ++ci) child = visit(l - 1, 2 * i + ci, 2 * j + cj) || child;
    }
    const double r = ratio(l, i, j, errors.delta(l, i, j));
    if (!child && r <= start) return false;
    fresh[size_t(l)][idx(l, i, j)] = morph_of(r);
    ++st.subdivided;
    return true;
  };
  for (int32_t by = 0; by < grid.blocks_y; ++by)
    for (int32_t bx = 0; bx < grid.blocks_x; ++bx) visit(grid.levels, bx, by);
  // Restricted: a subdivided square's neighbours exist, so their parents are subdivided, and
  // so are those parents' ancestors.
  auto force = [&](int32_t l, int32_t i, int32_t j) {
    for (; l <= grid.levels; ++l, i >>= 1, j >>= 1) {
      float& m = fresh[size_t(l)][idx(l, i, j)];
      if (m >= 0) return;
      m = morph_of(ratio(l, i, j, errors.delta(l, i, j)));
      ++st.forced;
    }
  };
  for (int32_t l = 1; l < grid.levels; ++l) {
    for (int32_t j = 0; j < grid.squares_y(l); ++j) {
      for (int32_t i = 0; i < grid.squares_x(l); ++i) {
        if (fresh[size_t(l)][idx(l, i, j)] < 0) continue;
        constexpr std::array<std::array<int32_t, 2>, 4> kSides = {{{0, -1}, {1, 0}, {0, 1}, {-1, 0}}};
        for (const auto& d : kSides) {
          const int32_t ni = i + d[0], nj = j + d[1];
          if (ni < 0 || nj < 0 || ni >= grid.squares_x(l) || nj >= grid.squares_y(l)) continue;
          const int32_t shift = grid.levels - l;
          if (grid.independent_blocks && ((ni >> shift) != (i >> shift) || (nj >> shift) != (j >> shift)))
            continue;
          force(l + 1, ni >> 1, nj >> 1);
        }
      }
    }
  }
  for (int32_t l = 1; l <= grid.levels; ++l) {
    for (int32_t j = 0; j < grid.squares_y(l); ++j)
      for (int32_t i = 0; i < grid.squares_x(l); ++i) {
        const float m = fresh[size_t(l)][idx(l, i, j)];
        state.set(l, i, j, m >= 0, m);
      }
  }
  for (uint8_t c : state.changed_blocks()) st.blocks_changed += c;
  return st;
}

namespace {

// The height a vertex at global sample (x, y) is drawn at: its own, blended from the surface of
// the leaf that had it not (the square whose subdivision introduced it) by that square's morph.
float vertex_height(const QuadtreeGrid& grid, const HeightGrid& heights, const QuadtreeState& state,
                    int64_t x, int64_t y, int32_t bx, int32_t by) {
  // With independent blocks a border vertex takes the morph of its own block's square alone.
  auto morph = [&](int32_t l, int32_t i, int32_t j) {
    const int32_t shift = grid.levels - l;
    if (grid.independent_blocks && ((i >> shift) != bx || (j >> shift) != by)) return 0.0f;
    return state.morph(l, i, j);
  };
  const double own = heights.at(x, y);
  const int32_t b = grid.levels;
  const int32_t kx = ctz_or(x, 62), ky = ctz_or(y, 62);
  const int32_t k = std::min(kx, ky);
  if (k >= b) return float(own);  // a block corner
  double target = own;
  float m = 1.0f;
  if (kx == ky) {
    // The centre of a level-(k + 1) square; a block's centre is always drawn.
    if (k + 1 == b) return float(own);
    const int32_t l = k + 2;
    const int64_t s = int64_t(1) << l;
    const int64_t pi = x >> l, pj = y >> l;
    const int64_t cx = pi * s + s / 2, cy = pj * s + s / 2;  // the parent's centre
    target = 0.5 * (double(heights.at(cx, cy)) + double(heights.at(2 * x - cx, 2 * y - cy)));
    m = state.morph(l, int32_t(pi), int32_t(pj));
  } else {
    // The midpoint of a side of level-(k + 1) squares, drawn where either is subdivided.
    const int32_t l = k + 1;
    const int64_t h = int64_t(1) << k;
    if (kx < ky) {  // a horizontal side: the squares above and below
      target = 0.5 * (double(heights.at(x - h, y)) + double(heights.at(x + h, y)));
      const int32_t i = int32_t(x >> l), j = int32_t(y >> l);
      m = std::max(morph(l, i, j - 1), morph(l, i, j));
    } else {  // a vertical side: the squares left and right
      target = 0.5 * (double(heights.at(x, y - h)) + double(heights.at(x, y + h)));
      const int32_t i = int32_t(x >> l), j = int32_t(y >> l);
      m = std::max(morph(l, i - 1, j), morph(l, i, j));
    }
  }
  return float(target + double(m) * (own - target));
}

// Calls tri(a, b, c) (global sample positions, counter-clockwise) for every triangle of a block.
template <typename Tri>
void for_each_triangle(const QuadtreeGrid& grid, const QuadtreeState& state, int32_t bx, int32_t by,
                       const Tri& tri) {
  std::function<void(int32_t, int32_t, int32_t)> emit = [&](int32_t l, int32_t i, int32_t j) {
    const int64_t s = int64_t(1) << l, h = s / 2, x0 = int64_t(i) * s, y0 = int64_t(j) * s;
    const std::array<int64_t, 2> c{x0 + h, y0 + h};
    if (state.subdivided(l, i, j)) {
      if (l > 1) {
        for (int32_t cj = 0; cj < 2; ++cj)
          for (int32_t ci = 0; ci < 2; ++ci) emit(l - 1, 2 * i + ci, 2 * j + cj);
        return;
      }
      // Full resolution: four unit cells, each split along its diagonal through the centre.
      const std::array<std::array<int64_t, 2>, 8> ring{{{x0, y0},
                                                        {x0 + 1, y0},
                                                        {x0 + 2, y0},
                                                        {x0 + 2, y0 + 1},
                                                        {x0 + 2, y0 + 2},
                                                        {x0 + 1, y0 + 2},
                                                        {x0, y0 + 2},
                                                        {x0, y0 + 1}}};
      for (size_t q = 0; q < 8; ++q) tri(c, ring[q], ring[(q + 1) % 8]);
      return;
    }
    // A leaf: a fan through the corners and the midpoints of sides whose neighbour is subdivided.
    std::array<std::array<int64_t, 2>, 8> ring{};
    size_t n = 0;
    const std::array<std::array<int64_t, 2>, 4> corner{
        {{x0, y0}, {x0 + s, y0}, {x0 + s, y0 + s}, {x0, y0 + s}}};
    constexpr std::array<std::array<int32_t, 2>, 4> kSides = {{{0, -1}, {1, 0}, {0, 1}, {-1, 0}}};
    for (size_t side = 0; side < 4; ++side) {
      ring[n++] = corner[side];
      const int32_t ni = i + kSides[side][0], nj = j + kSides[side][1], shift = grid.levels - l;
      const bool same_block = (ni >> shift) == bx && (nj >> shift) == by;
      if ((same_block || !grid.independent_blocks) && state.subdivided(l, ni, nj)) {
        const auto& a = corner[side];
        const auto& b = corner[(side + 1) % 4];
        ring[n++] = {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2};
      }
    }
    for (size_t q = 0; q < n; ++q) tri(c, ring[q], ring[(q + 1) % n]);
  };
  emit(grid.levels, bx, by);
}

}  // namespace

void block_mesh(const QuadtreeGrid& grid, const HeightGrid& heights, const QuadtreeState& state, int32_t bx,
                int32_t by, std::vector<QuadtreeVertex>& vertices,
                std::vector<std::array<uint32_t, 3>>& triangles, float skirt_depth) {
  vertices.clear();
  triangles.clear();
  const int32_t side = grid.block_size + 1;
  const int64_t ox = int64_t(bx) * grid.block_size, oy = int64_t(by) * grid.block_size;
  std::vector<int32_t> slot(size_t(side) * size_t(side), -1);
  auto vid = [&](const std::array<int64_t, 2>& p) {
    const int32_t lx = int32_t(p[0] - ox), ly = int32_t(p[1] - oy);
    int32_t& v = slot[size_t(ly) * size_t(side) + size_t(lx)];
    if (v < 0) {
      v = int32_t(vertices.size());
      vertices.push_back({lx, ly, vertex_height(grid, heights, state, p[0], p[1], bx, by)});
    }
    return uint32_t(v);
  };
  for_each_triangle(grid, state, bx, by, [&](const auto& a, const auto& b, const auto& c) {
    triangles.push_back({vid(a), vid(b), vid(c)});
  });
  if (skirt_depth <= 0) return;
  // The border's vertices in order around the block, each with a lowered copy.
  const int32_t B = grid.block_size;
  std::vector<uint32_t> ring;
  for (int32_t t = 0; t < 4 * B; ++t) {
    const int32_t along = t / B, u = t % B;
    const int32_t lx = along == 0 ? u : along == 1 ? B : along == 2 ? B - u : 0;
    const int32_t ly = along == 0 ? 0 : along == 1 ? u : along == 2 ? B : B - u;
    const int32_t v = slot[size_t(ly) * size_t(B + 1) + size_t(lx)];
    if (v >= 0) ring.push_back(uint32_t(v));
  }
  const uint32_t first_low = uint32_t(vertices.size());
  for (uint32_t v : ring)
    vertices.push_back({vertices[v].x, vertices[v].y, vertices[v].height - skirt_depth});
  for (size_t k = 0; k < ring.size(); ++k) {
    const size_t k1 = (k + 1) % ring.size();
    triangles.push_back({ring[k], ring[k1], first_low + uint32_t(k1)});
    triangles.push_back({ring[k], first_low + uint32_t(k1), first_low + uint32_t(k)});
  }
}

std::vector<float> block_side_profile(const QuadtreeGrid& grid, const HeightGrid& heights,
                                      const QuadtreeState& state, int32_t bx, int32_t by, int32_t side) {
  const int32_t B = grid.block_size;
  const int64_t ox = int64_t(bx) * B, oy = int64_t(by) * B;
  auto pos = [&](int32_t t) -> std::array<int64_t, 2> {
    switch (side) {
      case kSideTop: return {ox + t, oy};
      case kSideRight: return {ox + B, oy + t};
      case kSideBottom: return {ox + t, oy + B};
      default: return {ox, oy + t};
    }
  };
  // The border's vertices: the ends of the triangles' edges along the side.
  std::vector<int8_t> vertex(size_t(B) + 1, 0);
  for_each_triangle(grid, state, bx, by, [&](const auto& a, const auto& b, const auto& c) {
    for (const auto* p : {&a, &b, &c}) {
      for (int32_t t = 0; t <= B; ++t)
        if (pos(t) == *p) vertex[size_t(t)] = 1;
    }
  });
  std::vector<float> out(size_t(B) + 1);
  int32_t t0 = 0;
  for (int32_t t = 1; t <= B; ++t) {
    if (!vertex[size_t(t)]) continue;
    const auto a = pos(t0), b = pos(t);
    const double ha = vertex_height(grid, heights, state, a[0], a[1], bx, by);
    const double hb = vertex_height(grid, heights, state, b[0], b[1], bx, by);
    for (int32_t u = t0; u <= t; ++u)
      out[size_t(u)] = float(ha + (hb - ha) * double(u - t0) / double(t - t0));
    t0 = t;
  }
  return out;
}

std::vector<float> quadtree_skirt_depths(const QuadtreeGrid& grid, const QuadtreeErrors& errors,
                                         const QuadtreeState& state) {
  const int32_t b = grid.levels;
  // The largest error a block draws along its border.
  std::vector<float> border(size_t(grid.blocks_x) * size_t(grid.blocks_y), 0.0f);
  for (int32_t l = 1; l <= b; ++l) {
    const int32_t per = 1 << (b - l);  // squares per block side at this level
    for (int32_t j = 0; j < grid.squares_y(l); ++j) {
      for (int32_t i = 0; i < grid.squares_x(l); ++i) {
        const int32_t li = i % per, lj = j % per;
        if (li != 0 && lj != 0 && li != per - 1 && lj != per - 1) continue;  // not on the border
        const bool sub = state.subdivided(l, i, j);
        // Drawn: a leaf (its parent subdivided, or a root), or a square drawn at full resolution.
        const bool drawn = (!sub && (l == b || state.subdivided(l + 1, i >> 1, j >> 1))) || (sub && l == 1);
        if (!drawn) continue;
        float e = sub ? 0.0f : errors.delta(l, i, j);
        if (sub && state.morph(l, i, j) < 1) e = std::max(e, errors.delta(l, i, j));
        if (l < b && state.morph(l + 1, i >> 1, j >> 1) < 1)
          e = std::max(e, errors.delta(l + 1, i >> 1, j >> 1));
        float& blk = border[size_t(j / per) * size_t(grid.blocks_x) + size_t(i / per)];
        blk = std::max(blk, e);
      }
    }
  }
  std::vector<float> out(border.size(), 0.0f);
  constexpr std::array<std::array<int32_t, 2>, 4> kStep = {{{0, -1}, {1, 0}, {0, 1}, {-1, 0}}};
  for (int32_t by = 0; by < grid.blocks_y; ++by) {
    for (int32_t bx = 0; bx < grid.blocks_x; ++bx) {
      float depth = 0;
      for (const auto& d : kStep) {
        const int32_t nx = bx + d[0], ny = by + d[1];
        if (nx < 0 || ny < 0 || nx >= grid.blocks_x || ny >= grid.blocks_y) continue;
        depth = std::max(depth, border[size_t(by) * size_t(grid.blocks_x) + size_t(bx)] +
                                    border[size_t(ny) * size_t(grid.blocks_x) + size_t(nx)]);
      }
      out[size_t(by) * size_t(grid.blocks_x) + size_t(bx)] = depth > 0 ? std::ceil(depth) + 1.0f : 0.0f;
    }
  }
  return out;
}

std::vector<lod::ReplicaTriangle> replicate(const QuadtreeGrid& grid, const QuadtreeState& state) {
  std::vector<lod::ReplicaTriangle> out;
  for (int32_t by = 0; by < grid.blocks_y; ++by)
    for (int32_t bx = 0; bx < grid.blocks_x; ++bx)
      for_each_triangle(grid, state, bx, by, [&](const auto& a, const auto& b, const auto& c) {
        lod::ReplicaTriangle t;
        t.x = {a[0], b[0], c[0]};
        t.y = {a[1], b[1], c[1]};
        out.push_back(t);
      });
  return out;
}

std::vector<float> displayed_surface(const QuadtreeGrid& grid, const HeightGrid& heights,
                                     const QuadtreeState& state) {
  const RectI cov = grid.covered();
  std::vector<float> out(size_t(cov.area()), 0.0f);
  for (int32_t by = 0; by < grid.blocks_y; ++by)
    for (int32_t bx = 0; bx < grid.blocks_x; ++bx)
      for_each_triangle(grid, state, bx, by, [&](const auto& a, const auto& b, const auto& c) {
        const double ha = vertex_height(grid, heights, state, a[0], a[1], bx, by);
        const double hb = vertex_height(grid, heights, state, b[0], b[1], bx, by);
        const double hc = vertex_height(grid, heights, state, c[0], c[1], bx, by);
        for_each_point(a, b, c, [&](int64_t x, int64_t y, double wa, double wb, double wc) {
          out[size_t(y * cov.width() + x)] = float(wa * ha + wb * hb + wc * hc);
        });
      });
  return out;
}

int64_t triangle_count(const QuadtreeGrid& grid, const QuadtreeState& state) {
  int64_t n = 0;
  for (int32_t by = 0; by < grid.blocks_y; ++by)
    for (int32_t bx = 0; bx < grid.blocks_x; ++bx)
      for_each_triangle(grid, state, bx, by, [&](const auto&, const auto&, const auto&) { ++n; });
  return n;
}

}  // namespace loam::lod
