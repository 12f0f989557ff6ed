// Ulrich's adaptive-quadtree continuous level of detail ("Continuous LOD terrain meshing using
// adaptive quadtrees", 2000) as pure logic, over blocks of the world: the squares' errors, the
// view-dependent subdivision with the L1-norm box distance test, a restricted quadtree (no
// crack, no T-junction), geomorphed vertex heights, and the mesh rebuilt incrementally: only
// the blocks whose subdivision changed are triangulated again. No GL: the renderer and the
// `lod` suite draw what this decides; the tests check it on the CPU.
//
// Squares: the world is covered by blocks of B = 2^b samples (the quadtree roots, sharing
// their borders: block (bx, by) covers samples [bx B, bx B + B] x [by B, by B + B]); a square
// of level l (1 <= l <= b) has side 2^l samples, its four corners and its centre. A leaf is
// drawn as a fan around its centre through its corners and, on each side, the side's midpoint
// where the square across that side is subdivided; a subdivided level-1 square is drawn at
// full resolution. Restricted: a leaf's neighbours are at most one level finer, which the
// subdivision enforces, so every side carries at most its midpoint.
//
// Error (the geomipmap's metric, per square): delta is the largest |height - leaf surface| over
// the square's samples, whichever of its sides carry midpoints. A square is subdivided when
// delta K sqrt(3) / d1 > tau / 2: d1 is the L1 distance from the camera to the square's
// bounding box (Ulrich's cheap box test), K the pixels per radian; sqrt(3) d2 >= d1. The
// subtree's largest delta lets a whole far subtree be skipped by one test.
//
// Geomorphing: a square's new vertices (its children's centres, its sides' midpoints) rise
// from its leaf surface to their heights as delta K sqrt(3) / d1 goes from tau / 2 to tau, so
// a subdivision moves nothing at first and the drawn error stays within tau pixels.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "client/lod/geomipmap.h"
#include "client/lod/mesh_check.h"
#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam::lod {

struct QuadtreeGrid {
  int32_t block_size = 64;  // B = 2^b samples per block side
  int32_t levels = 6;       // b: squares of levels 1..b, the roots at b
  int32_t blocks_x = 0, blocks_y = 0;
  int64_t width = 0, height = 0;  // the world's samples
  // Leitao & Carmo's tiled blocks with skirts: each block's quadtree is restricted and drawn on
  // its own (no square reads a neighbour across a block border), so blocks may crack where
  // they meet and skirts (quadtree_skirt_depths) hide it. False: restricted across borders.
  bool independent_blocks = false;

  // Errors: block_size not a power of two in 4..256, or an empty world.
  static Result<QuadtreeGrid> make(int64_t width, int64_t height, int32_t block_size);
  // Squares of level l per row and per column.
  int32_t squares_x(int32_t l) const { return blocks_x << (levels - l); }
  int32_t squares_y(int32_t l) const { return blocks_y << (levels - l); }
  RectI covered() const;  // vertex positions: [0, blocks_x B] x [0, blocks_y B]
};

// Per square (level 1..b): delta, the subtree's largest delta, and the height bounds.
class QuadtreeErrors {
 public:
  static QuadtreeErrors compute(const QuadtreeGrid& grid, const HeightGrid& heights);
  // Recomputes the squares (every level) holding a sample of `changed`; returns how many.
  int64_t update(const QuadtreeGrid& grid, const HeightGrid& heights, const RectI& changed);
  float delta(int32_t l, int32_t i, int32_t j) const { return squares_[size_t(l)][index(l, i, j)].delta; }
  float subtree(int32_t l, int32_t i, int32_t j) const { return squares_[size_t(l)][index(l, i, j)].subtree; }
  uint16_t min_height(int32_t l, int32_t i, int32_t j) const {
    return squares_[size_t(l)][index(l, i, j)].lo;
  }
  uint16_t max_height(int32_t l, int32_t i, int32_t j) const {
    return squares_[size_t(l)][index(l, i, j)].hi;
  }

 private:
  struct Square {
    float delta = 0, subtree = 0;
    uint16_t lo = 0, hi = 0;
  };
  size_t index(int32_t l, int32_t i, int32_t j) const {
    return size_t(j) * size_t(row_[size_t(l)]) + size_t(i);
  }
  void compute_square(const QuadtreeGrid& grid, const HeightGrid& heights, int32_t l, int32_t i, int32_t j);
  std::vector<int32_t> row_;                  // squares per row, per level
  std::vector<std::vector<Square>> squares_;  // per level (0 unused)
};

// The subdivision a view chose, and the morph of each subdivided square.
class QuadtreeState {
 public:
  explicit QuadtreeState(const QuadtreeGrid& grid);
  bool subdivided(int32_t l, int32_t i, int32_t j) const;  // false outside the grid
  float morph(int32_t l, int32_t i, int32_t j) const;      // 0 when not subdivided
  void set(int32_t l, int32_t i, int32_t j, bool on, float morph);
  // Blocks whose subdivision or morphs changed since the last clear (row order).
  const std::vector<uint8_t>& changed_blocks() const { return changed_; }
  void clear_changed() { std::fill(changed_.begin(), changed_.end(), 0); }
  const QuadtreeGrid& grid() const { return grid_; }

 private:
  size_t index(int32_t l, int32_t i, int32_t j) const {
    return size_t(j) * size_t(grid_.squares_x(l)) + size_t(i);
  }
  QuadtreeGrid grid_;
  std::vector<std::vector<float>> morph_;  // per level; < 0: not subdivided
  std::vector<uint8_t> changed_;
};

struct QuadtreeSelectStats {
  int64_t squares_tested = 0;
  int64_t subdivided = 0;
  int64_t forced = 0;  // subdivided only to keep the quadtree restricted
  int32_t blocks_changed = 0;
};

// Chooses the subdivision for the view, top-down from every block with early-outs, then makes
// it restricted; marks the blocks that changed in `state`. `morph` false: no geomorphing
// (subdivided from tau, vertices at their heights).
QuadtreeSelectStats select_quadtree(const QuadtreeGrid& grid, const QuadtreeErrors& errors,
                                    const HeightScale& scale, const LodView& view, QuadtreeState& state,
                                    bool morph = true);

// Per block (row order), with independent blocks, the depth (height units) its skirts hang
// below its border: at least the largest gap along the border between its drawn surface and a
// neighbour's, bounded by the sum of the two blocks' border errors (the largest delta of a leaf
// touching the border, or of its parent while that parent morphs).
std::vector<float> quadtree_skirt_depths(const QuadtreeGrid& grid, const QuadtreeErrors& errors,
                                         const QuadtreeState& state);

// A vertex as drawn: block-local position and height (height units, fractional while morphing).
struct QuadtreeVertex {
  int32_t x = 0, y = 0;
  float height = 0;
};

// The triangles of block (bx, by): vertices and counter-clockwise index triples (positive area
// with y along +gy). What the renderer uploads for a changed block.
// `skirt_depth` > 0 adds the block's skirt: its border vertices lowered by that much, joined to
// the border by vertical quads.
void block_mesh(const QuadtreeGrid& grid, const HeightGrid& heights, const QuadtreeState& state, int32_t bx,
                int32_t by, std::vector<QuadtreeVertex>& vertices,
                std::vector<std::array<uint32_t, 3>>& triangles, float skirt_depth = 0);

// The drawn height (height units) along side `side` (Side of geomipmap.h) of block (bx, by) at
// every sample of it, linear between the border's vertices (for the skirt tests).
std::vector<float> block_side_profile(const QuadtreeGrid& grid, const HeightGrid& heights,
                                      const QuadtreeState& state, int32_t bx, int32_t by, int32_t side);

// CPU replica over every block (mip-0 sample coordinates), for lod::check_watertight over
// grid.covered(); and the drawn surface's height at every covered sample, row-major.
std::vector<lod::ReplicaTriangle> replicate(const QuadtreeGrid& grid, const QuadtreeState& state);
std::vector<float> displayed_surface(const QuadtreeGrid& grid, const HeightGrid& heights,
                                     const QuadtreeState& state);
int64_t triangle_count(const QuadtreeGrid& grid, const QuadtreeState& state);

}  // namespace loam::lod
