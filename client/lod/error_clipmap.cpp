#include "client/lod/error_clipmap.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <map>
#include <queue>
#include <string>

#include "client/lod/projected_error.h"

namespace loam::lod {

Result<ClipmapBlockGrid> ClipmapBlockGrid::make(int64_t width, int64_t height, int32_t block_size,
                                                int32_t levels) {
  const int32_t c = block_size - 1;
  if (c < 4 || c > 64 || !std::has_single_bit(uint32_t(c))) {
    return make_error(
        ErrorCode::kInvalidArgument, "error_clipmap.block_size",
        "must be 2^k + 1 with 2 <= k <= 6 (5, 9, 17, 33 or 65), got " + std::to_string(block_size));
  }
  if (levels < 1 || levels > 24)
    return make_error(ErrorCode::kInvalidArgument, "error_clipmap.levels", "must be 1..24");
  if (width < 2 || height < 2)
    return make_error(ErrorCode::kInvalidArgument, "error_clipmap.world", "needs at least 2 x 2 samples");
  ClipmapBlockGrid g;
  g.block_size = block_size;
  g.levels = levels;
  g.width = width;
  g.height = height;
  return g;
}

GeomipmapGrid ClipmapBlockGrid::patch_grid() const {
  auto g = GeomipmapGrid::make(block_size, block_size, block_size);
  return *g;  // block_size was checked by make()
}

// --- errors ---

const ClipmapErrorPyramid::Entry* ClipmapErrorPyramid::find(int32_t l, int64_t bx, int64_t by) const {
  if (l < 0 || size_t(l) >= level_.size()) return nullptr;
  const Level& v = level_[size_t(l)];
  if (!v.blocks.contains(bx, by)) return nullptr;
  return &v.entries[size_t((by - v.blocks.y0) * v.blocks.width() + (bx - v.blocks.x0))];
}

float ClipmapErrorPyramid::error(int32_t l, int64_t bx, int64_t by) const {
  const Entry* e = find(l, bx, by);
  return e ? e->error : 0.0f;
}
uint16_t ClipmapErrorPyramid::min_height(int32_t l, int64_t bx, int64_t by) const {
  const Entry* e = find(l, bx, by);
  return e ? e->lo : 0;
}
uint16_t ClipmapErrorPyramid::max_height(int32_t l, int64_t bx, int64_t by) const {
  const Entry* e = find(l, bx, by);
  return e ? e->hi : 0;
}

size_t ClipmapErrorPyramid::bytes() const {
  size_t n = 0;
  for (const Level& v : level_) n += v.entries.size() * sizeof(Entry);
  return n;
}

namespace {

// The largest |sample - union-jack surface of cells `s` samples wide| over a (k + 1)^2 grid of
// samples (k a multiple of s) whose low corner is sample (gx, gy) of the same grid.
double surface_error(std::span<const uint16_t> v, int64_t k, int64_t s, int64_t gx, int64_t gy) {
  const int64_t w = k + 1;
  double worst = 0;
  for (int64_t y = 0; y <= k; ++y) {
    const int64_t qy = std::min(y / s * s, k - s);
    for (int64_t x = 0; x <= k; ++x) {
      if (x % s == 0 && y % s == 0) continue;  // a vertex of the coarser surface: exact
      const int64_t qx = std::min(x / s * s, k - s);
      const double h00 = v[size_t(qy * w + qx)], h10 = v[size_t(qy * w + qx + s)];
      const double h01 = v[size_t((qy + s) * w + qx)], h11 = v[size_t((qy + s) * w + qx + s)];
      const double surface =
          union_jack_surface(h00, h10, h01, h11, double(x - qx) / double(s), double(y - qy) / double(s),
                             union_jack_main_diagonal(gx + qx, gy + qy, s));
      worst = std::max(worst, std::abs(double(v[size_t(y * w + x)]) - surface));
    }
  }
  return worst;
}

// Rounded up so that the bound holds in float.
float bound(double worst) { return worst == 0 ? 0.0f : std::nextafter(float(worst), INFINITY); }

}  // namespace

void ClipmapErrorPyramid::compute_block(const ClipmapBlockGrid& grid, const MipReader& read, int32_t l,
                                        int64_t bx, int64_t by) {
  Level& v = level_[size_t(l)];
  Entry& e = v.entries[size_t((by - v.blocks.y0) * v.blocks.width() + (bx - v.blocks.x0))];
  float children = 0;
  uint16_t lo = 65535, hi = 0;
  if (l > 0) {
    for (int64_t j = 0; j < 2; ++j) {
      for (int64_t i = 0; i < 2; ++i) {
        if (const Entry* c = find(l - 1, 2 * bx + i, 2 * by + j)) {
          children = std::max(children, c->error);
          lo = std::min(lo, c->lo), hi = std::max(hi, c->hi);
        }
      }
    }
  }
  if (l <= exact_levels_) {
    // Every mip-0 sample against the level-l surface.
    const RectI r = grid.block_rect(l, bx, by);
    scratch_.resize(size_t(r.area()));
    read(0, r, scratch_);
    const auto [mn, mx] = std::minmax_element(scratch_.begin(), scratch_.end());
    e.lo = *mn, e.hi = *mx;
    e.error = l == 0 ? 0.0f
                     : std::max(children,
                                bound(surface_error(scratch_, grid.span(l), int64_t(1) << l, r.x0, r.y0)));
    return;
  }
  // The children's bound plus the level-(l-1) samples against the level-l surface. The samples
  // join the height range: where the finer window does not hold the children, they are what
  // can be drawn there (mips are decimated, so where it does, the children's range holds them).
  const int64_t k = 2 * int64_t(grid.cells());
  const RectI r{bx * k, by * k, bx * k + k + 1, by * k + k + 1};
  scratch_.resize(size_t(r.area()));
  read(l - 1, r, scratch_);
  const auto [mn, mx] = std::minmax_element(scratch_.begin(), scratch_.end());
  e.lo = std::min(lo, *mn), e.hi = std::max(hi, *mx);
  e.error = bound(double(children) + surface_error(scratch_, k, 2, r.x0, r.y0));
}

RectI blocks_inside(const ClipmapBlockGrid& grid, int32_t l, const RectI& r) {
  const int64_t c = grid.cells();
  const int32_t L = grid.levels;
  // Blocks whose vertices [b c, b c + c] lie in the region, none before the world's start ...
  const int64_t x0 = std::max<int64_t>(0, ceil_div(r.x0, c)), y0 = std::max<int64_t>(0, ceil_div(r.y0, c));
  int64_t x1 = floor_div(r.x1 - 1 - c, c) + 1, y1 = floor_div(r.y1 - 1 - c, c) + 1;
  // ... and within the roots' blocks: the coarsest level's that hold a world sample.
  x1 = std::min<int64_t>(x1, int64_t(grid.blocks_x(L - 1)) << (L - 1 - l));
  y1 = std::min<int64_t>(y1, int64_t(grid.blocks_y(L - 1)) << (L - 1 - l));
  return {x0, y0, std::max(x0, x1), std::max(y0, y1)};
}

ClipmapErrorPyramid ClipmapErrorPyramid::windowed(const ClipmapBlockGrid& grid, int32_t exact_levels) {
  ClipmapErrorPyramid p;
  p.exact_levels_ = std::max(exact_levels, 0);
  p.level_.resize(size_t(grid.levels));
  return p;
}

ClipmapErrorPyramid ClipmapErrorPyramid::compute(const ClipmapBlockGrid& grid, const MipReader& read,
                                                 int32_t exact_levels) {
  ClipmapErrorPyramid p = windowed(grid, exact_levels);
  std::vector<RectI> all;
  for (int32_t l = 0; l < grid.levels; ++l) all.push_back({0, 0, grid.blocks_x(l), grid.blocks_y(l)});
  p.move_windows(grid, read, all);
  return p;
}

int64_t ClipmapErrorPyramid::move_windows(const ClipmapBlockGrid& grid, const MipReader& read,
                                          std::span<const RectI> windows) {
  level_.resize(size_t(grid.levels));
  int64_t computed = 0;
  // The finer level's windows before and after, and which of its new window's blocks were
  // computed in this move: a parent is recomputed when a child changed or entered or left.
  // (Empty finer_dirty: nothing was computed there.)
  RectI finer_old, finer_new;
  std::vector<uint8_t> finer_dirty;
  bool finer_changed = false;
  for (int32_t l = 0; l < grid.levels; ++l) {
    const RectI asked = size_t(l) < windows.size() ? windows[size_t(l)] : RectI{};
    const RectI w = asked.intersect({0, 0, grid.blocks_x(l), grid.blocks_y(l)});
    Level& old = level_[size_t(l)];
    Level next;
    next.blocks = w.empty() ? RectI{} : w;
    if (next.blocks == old.blocks && !finer_changed) {
      // A camera that stayed within its blocks: the level is as it was (no copy, no allocation).
      finer_old = finer_new = old.blocks;
      finer_dirty.clear();
      continue;
    }
    next.entries.resize(size_t(next.blocks.area()));
    std::vector<uint8_t> dirty(next.entries.size(), 0);
    for (int64_t by = next.blocks.y0; by < next.blocks.y1; ++by) {
      for (int64_t bx = next.blocks.x0; bx < next.blocks.x1; ++bx) {
        const size_t i = size_t((by - next.blocks.y0) * next.blocks.width() + (bx - next.blocks.x0));
        bool keep = old.blocks.contains(bx, by);
        for (int64_t j = 0; j < 2 && keep && l > 0; ++j) {
          for (int64_t k = 0; k < 2 && keep; ++k) {
            const int64_t cx = 2 * bx + k, cy = 2 * by + j;
            const bool was = finer_old.contains(cx, cy), is = finer_new.contains(cx, cy);
            keep = was == is &&
                   (!is || finer_dirty.empty() ||
                    finer_dirty[size_t((cy - finer_new.y0) * finer_new.width() + (cx - finer_new.x0))] == 0);
          }
        }
        if (keep) {
          next.entries[i] =
              old.entries[size_t((by - old.blocks.y0) * old.blocks.width() + (bx - old.blocks.x0))];
        } else {
          dirty[i] = 1;
        }
      }
    }
    finer_old = old.blocks;
    old = std::move(next);
    finer_new = old.blocks;
    int64_t here = 0;
    for (int64_t by = finer_new.y0; by < finer_new.y1; ++by) {
      for (int64_t bx = finer_new.x0; bx < finer_new.x1; ++bx) {
        if (dirty[size_t((by - finer_new.y0) * finer_new.width() + (bx - finer_new.x0))] == 0) continue;
        compute_block(grid, read, l, bx, by);
        ++here;
      }
    }
    computed += here;
    finer_changed = here > 0 || finer_old != finer_new;
    finer_dirty = std::move(dirty);
  }
  return computed;
}

std::vector<ClipmapBlockId> ClipmapErrorPyramid::update(const ClipmapBlockGrid& grid, const MipReader& read,
                                                        const RectI& changed) {
  std::vector<ClipmapBlockId> out;
  if (changed.empty()) return out;
  for (int32_t l = 0; l < grid.levels && size_t(l) < level_.size(); ++l) {
    const int64_t s = grid.span(l);
    const RectI& w = level_[size_t(l)].blocks;
    // Block b holds samples [b s, b s + s].
    const int64_t x0 = std::max<int64_t>(w.x0, ceil_div(changed.x0 - s, s)),
                  x1 = std::min<int64_t>(w.x1 - 1, floor_div(changed.x1 - 1, s));
    const int64_t y0 = std::max<int64_t>(w.y0, ceil_div(changed.y0 - s, s)),
                  y1 = std::min<int64_t>(w.y1 - 1, floor_div(changed.y1 - 1, s));
    for (int64_t by = y0; by <= y1; ++by) {
      for (int64_t bx = x0; bx <= x1; ++bx) {
        compute_block(grid, read, l, bx, by);
        out.push_back({l, int32_t(bx), int32_t(by)});
      }
    }
  }
  return out;
}

// --- selection ---

namespace {

constexpr int8_t kAbsent = 0, kLeaf = 1, kSplit = 2;

// The blocks of one level inside its region: their state and, for leaves, their morph.
struct LevelBlocks {
  int64_t x0 = 0, y0 = 0;
  int64_t nx = 0, ny = 0;
  std::vector<int8_t> state;
  std::vector<float> morph;
  bool has(int64_t bx, int64_t by) const { return bx >= x0 && by >= y0 && bx < x0 + nx && by < y0 + ny; }
  size_t at(int64_t bx, int64_t by) const { return size_t((by - y0) * nx + (bx - x0)); }
  int8_t get(int64_t bx, int64_t by) const { return has(bx, by) ? state[at(bx, by)] : kAbsent; }
};

constexpr std::array<std::array<int64_t, 2>, 4> kStep = {{{0, -1}, {1, 0}, {0, 1}, {-1, 0}}};  // per Side

}  // namespace

ErrorClipmapSelection select_error_clipmap(const ClipmapBlockGrid& grid, const ClipmapErrorPyramid& errors,
                                           const HeightScale& scale, const LodView& view,
                                           std::span<const RectI> regions, bool morph,
                                           const BlockFilter& split_only, int64_t max_blocks) {
  ErrorClipmapSelection sel;
  const int32_t L = std::min<int32_t>(grid.levels, int32_t(regions.size()));
  if (L < 1) return sel;
  std::vector<LevelBlocks> lv;
  lv.resize(size_t(L));
  for (int32_t l = 0; l < L; ++l) {
    LevelBlocks& b = lv[size_t(l)];
    ClipmapBlockGrid g = grid;
    g.levels = L;
    const RectI in = blocks_inside(g, l, regions[size_t(l)]);
    b.x0 = in.x0, b.y0 = in.y0, b.nx = in.width(), b.ny = in.height();
    b.state.assign(size_t(b.nx * b.ny), kAbsent);
    b.morph.assign(size_t(b.nx * b.ny), 0.0f);
  }
  const double mps = scale.meters_per_sample, mpu = scale.meters_per_unit;
  // The vertical error (m) that shows as one pixel at worst at the block's box.
  auto meters_per_px = [&](int32_t l, int64_t bx, int64_t by) {
    const RectI r = grid.block_rect(l, bx, by);
    const std::array<double, 3> lo{double(r.x0) * mps, double(r.y0) * mps,
                                   scale.meters(errors.min_height(l, bx, by))};
    const std::array<double, 3> hi{double(r.x1 - 1) * mps, double(r.y1 - 1) * mps,
                                   scale.meters(errors.max_height(l, bx, by))};
    const double k = pixels_per_vertical_meter(view, lo, hi);
    return k > 0 ? 1.0 / k : std::numeric_limits<double>::infinity();
  };
  auto delta = [&](int32_t l, int64_t bx, int64_t by) { return double(errors.error(l, bx, by)) * mpu; };
  // The block's screen error (px) at worst.
  auto screen_px = [&](int32_t l, int64_t bx, int64_t by) {
    const double e = delta(l, bx, by);
    return e > 0 ? e / meters_per_px(l, bx, by) : 0.0;
  };
  auto children_fit = [&](int32_t l, int64_t bx, int64_t by) {
    const LevelBlocks& f = lv[size_t(l - 1)];
    return f.has(2 * bx, 2 * by) && f.has(2 * bx + 1, 2 * by + 1);
  };
  auto split = [&](int32_t l, int64_t bx, int64_t by) {
    lv[size_t(l)].state[lv[size_t(l)].at(bx, by)] = kSplit;
    LevelBlocks& f = lv[size_t(l - 1)];
    for (int64_t j = 0; j < 2; ++j)
      for (int64_t i = 0; i < 2; ++i) f.state[f.at(2 * bx + i, 2 * by + j)] = kLeaf;
  };

  // Top-down, the block showing the largest error first: split while it shows more than the
  // budget, the finer level holds its children and the block count allows.
  struct Candidate {
    double px;
    ClipmapBlockId id;
    bool operator<(const Candidate& o) const { return px < o.px; }
  };
  std::priority_queue<Candidate> queue;
  auto drawn = [&](int32_t l, int64_t bx, int64_t by) { return !split_only || split_only(l, bx, by); };
  int64_t blocks = 0;  // leaves split_only lets through: the blocks a view draws
  // A drawn leaf: counted, and a candidate for a split.
  auto add_drawn = [&](int32_t l, int64_t bx, int64_t by) {
    ++blocks;
    if (l > 0) queue.push({screen_px(l, bx, by), {l, int32_t(bx), int32_t(by)}});
  };
  const LevelBlocks& top = lv[size_t(L - 1)];
  for (int64_t by = top.y0; by < top.y0 + top.ny; ++by) {
    for (int64_t bx = top.x0; bx < top.x0 + top.nx; ++bx) {
      lv[size_t(L - 1)].state[top.at(bx, by)] = kLeaf;
      if (drawn(L - 1, bx, by)) add_drawn(L - 1, bx, by);
    }
  }
  if (top.nx > 0 && top.ny > 0) {
    const int64_t s = grid.span(L - 1);
    sel.covered = {top.x0 * s, top.y0 * s, (top.x0 + top.nx) * s + 1, (top.y0 + top.ny) * s + 1};
  }
  double tolerance = view.tolerance_px;
  while (!queue.empty()) {
    const Candidate c = queue.top();
    const ClipmapBlockId& b = c.id;
    ++sel.stats.blocks_tested;
    if (c.px <= view.tolerance_px) break;  // every block left is within the budget
    if (!children_fit(b.level, b.bx, b.by)) {
      ++sel.stats.held_back;
      queue.pop();
      continue;
    }
    std::array<bool, 4> child_drawn{};  // row order; each child's frustum test made once
    int64_t visible = 0;
    for (int64_t k = 0; k < 4; ++k) {
      child_drawn[size_t(k)] = drawn(b.level - 1, 2 * b.bx + (k & 1), 2 * b.by + (k >> 1));
      visible += child_drawn[size_t(k)] ? 1 : 0;
    }
    if (max_blocks > 0 && blocks - 1 + visible > max_blocks) {
      // The block count is spent: the budget becomes what this block shows, the most any
      // block left shows (the morphs below blend for it).
      tolerance = c.px;
      sel.stats.budget_bound = true;
      break;
    }
    queue.pop();
    split(b.level, b.bx, b.by);
    ++sel.stats.split;
    --blocks;
    for (int64_t k = 0; k < 4; ++k)
      if (child_drawn[size_t(k)]) add_drawn(b.level - 1, 2 * b.bx + (k & 1), 2 * b.by + (k >> 1));
  }
  sel.stats.tolerance_px = tolerance;
  // The vertical error (m) the budget allows at the block's box.
  auto allowed = [&](int32_t l, int64_t bx, int64_t by) { return tolerance * meters_per_px(l, bx, by); };

  // Restricted: finest first, a leaf's neighbour more than one level coarser is split down to
  // one level coarser. Splits only make leaves finer than the coarse leaf, at levels above l,
  // so leaves already visited stay restricted.
  for (int32_t l = 0; l + 2 < L; ++l) {
    LevelBlocks& b = lv[size_t(l)];
    for (int64_t by = b.y0; by < b.y0 + b.ny; ++by) {
      for (int64_t bx = b.x0; bx < b.x0 + b.nx; ++bx) {
        if (b.state[b.at(bx, by)] != kLeaf) continue;
        for (const auto& step : kStep) {
          const int64_t nx = bx + step[0], ny = by + step[1];
          if (b.get(nx, ny) != kAbsent || lv[size_t(l + 1)].get(nx >> 1, ny >> 1) != kAbsent) continue;
          int32_t k = l + 2;
          while (k < L && lv[size_t(k)].get(nx >> (k - l), ny >> (k - l)) != kLeaf) ++k;
          if (k >= L) continue;  // beyond the drawn area
          for (; k > l + 1; --k) {
            const int64_t px = nx >> (k - l), py = ny >> (k - l);
            if (!children_fit(k, px, py)) {
              ++sel.stats.unrestricted;
              break;
            }
            split(k, px, py);
            ++sel.stats.forced;
          }
        }
      }
    }
  }

  // Morphs: toward the parent's surface as far as the budget allows.
  for (int32_t l = 0; l + 1 < L; ++l) {
    LevelBlocks& b = lv[size_t(l)];
    for (int64_t by = b.y0; by < b.y0 + b.ny; ++by) {
      for (int64_t bx = b.x0; bx < b.x0 + b.nx; ++bx) {
        if (b.state[b.at(bx, by)] != kLeaf || !morph) continue;
        const double own = delta(l, bx, by), parent = delta(l + 1, bx >> 1, by >> 1), a = allowed(l, bx, by);
        float m = 0;
        if (a >= parent) {
          m = 1;
        } else if (parent > own) {
          m = float(std::clamp((a - own) / (parent - own), 0.0, 1.0));
        }
        b.morph[b.at(bx, by)] = m;
      }
    }
  }

  // Sides, and the leaves in order.
  for (int32_t l = 0; l < L; ++l) {
    const LevelBlocks& b = lv[size_t(l)];
    for (int64_t by = b.y0; by < b.y0 + b.ny; ++by) {
      for (int64_t bx = b.x0; bx < b.x0 + b.nx; ++bx) {
        if (b.state[b.at(bx, by)] != kLeaf) continue;
        ClipmapBlock out;
        out.id = {l, int32_t(bx), int32_t(by)};
        out.lod.level = 0;
        out.lod.morph = b.morph[b.at(bx, by)];
        for (size_t side = 0; side < 4; ++side) {
          const int64_t nx = bx + kStep[side][0], ny = by + kStep[side][1];
          out.lod.edge_level[side] = 0;
          out.lod.edge_morph[side] = out.lod.morph;
          const int8_t same = b.get(nx, ny);
          if (same == kLeaf) {
            out.lod.edge_morph[side] = std::max(out.lod.morph, b.morph[b.at(nx, ny)]);
          } else if (same == kAbsent && l + 1 < L && lv[size_t(l + 1)].get(nx >> 1, ny >> 1) == kLeaf) {
            const LevelBlocks& up = lv[size_t(l + 1)];
            out.lod.edge_level[side] = 1;
            out.lod.edge_morph[side] = up.morph[up.at(nx >> 1, ny >> 1)];
          }
        }
        sel.blocks.push_back(out);
      }
    }
  }
  return sel;
}

float block_vertex_height(const ClipmapBlockGrid& grid, const HeightGrid& heights, const ClipmapBlock& block,
                          int32_t lx, int32_t ly) {
  const int64_t c = grid.cells();
  // One captured reference: the callable fits std::function's inline storage (no allocation
  // per vertex).
  const struct {
    const HeightGrid& heights;
    int64_t x0, y0, s;
  } b{heights, int64_t(block.id.bx) * c, int64_t(block.id.by) * c, int64_t(1) << block.id.level};
  return morphed_vertex_height(
      grid.cells(), std::countr_zero(uint32_t(grid.cells())) + 1, block.lod, lx, ly,
      [&b](int32_t x, int32_t y) { return double(b.heights.at((b.x0 + x) * b.s, (b.y0 + y) * b.s)); });
}

namespace {

using Tri = std::array<uint16_t, 3>;

// Calls fn(block, triangles) for every block, the triangles built once per side pattern.
template <typename Fn>
void for_each_block_triangles(const ClipmapBlockGrid& grid, const ErrorClipmapSelection& sel, const Fn& fn) {
  const GeomipmapGrid patch = grid.patch_grid();
  std::map<std::array<int8_t, 4>, std::vector<Tri>> cache;
  for (const ClipmapBlock& b : sel.blocks) {
    auto it = cache.find(b.lod.edge_level);
    if (it == cache.end())
      it = cache.emplace(b.lod.edge_level, patch_triangles(patch, 0, b.lod.edge_level)).first;
    fn(b, it->second);
  }
}

}  // namespace

std::vector<lod::ReplicaTriangle> replicate(const ClipmapBlockGrid& grid, const ErrorClipmapSelection& sel) {
  std::vector<lod::ReplicaTriangle> out;
  const int64_t n = grid.block_size, c = grid.cells();
  for_each_block_triangles(grid, sel, [&](const ClipmapBlock& b, const std::vector<Tri>& tris) {
    const int64_t s = int64_t(1) << b.id.level;
    for (const Tri& t : tris) {
      lod::ReplicaTriangle r;
      for (size_t k = 0; k < 3; ++k) {
        r.x[k] = (int64_t(b.id.bx) * c + t[k] % n) * s;
        r.y[k] = (int64_t(b.id.by) * c + t[k] / n) * s;
      }
      out.push_back(r);
    }
  });
  return out;
}

std::vector<float> displayed_surface(const ClipmapBlockGrid& grid, const HeightGrid& heights,
                                     const ErrorClipmapSelection& sel) {
  const RectI& cov = sel.covered;
  std::vector<float> out(size_t(cov.area()), 0.0f);
  const int64_t n = grid.block_size, c = grid.cells();
  for_each_block_triangles(grid, sel, [&](const ClipmapBlock& b, const std::vector<Tri>& tris) {
    const int64_t s = int64_t(1) << b.id.level;
    for (const Tri& t : tris) {
      std::array<int64_t, 3> x{}, y{};
      std::array<double, 3> z{};
      for (size_t k = 0; k < 3; ++k) {
        z[k] = block_vertex_height(grid, heights, b, int32_t(t[k] % n), int32_t(t[k] / n));
        // Past the world's last sample the renderer draws a vertex at it.
        x[k] = std::min((int64_t(b.id.bx) * c + t[k] % n) * s, grid.width - 1);
        y[k] = std::min((int64_t(b.id.by) * c + t[k] / n) * s, grid.height - 1);
      }
      rasterize_heights(x, y, z, cov, out);
    }
  });
  return out;
}

int64_t triangle_count(const ClipmapBlockGrid& grid, const ErrorClipmapSelection& sel) {
  int64_t n = 0;
  for_each_block_triangles(
      grid, sel, [&](const ClipmapBlock&, const std::vector<Tri>& tris) { n += int64_t(tris.size()); });
  return n;
}

}  // namespace loam::lod
