// The error-driven clipmap as pure logic: the clipmap's levels (level l spaces vertices 2^l
// mip-0 samples and reads mip l, held in a region of the level's grid around the camera), drawn
// as a restricted quadtree of blocks chosen by screen-space error instead of rings chosen by
// distance. No GL: the renderer (client/render/error_clipmap_renderer.h) draws what this
// decides, and the tests check it on a CPU replica.
//
// Blocks: a level-l block is block_size = 2^k + 1 vertices per side at that level's spacing,
// so block (bx, by) of level l covers mip-0 samples [bx C, bx C + C] per axis, C = cells << l;
// its four children are the level-(l - 1) blocks inside it. Mips are decimated (protocol/
// world.h), so a block drawn at level l is the union-jack surface through its level-l samples,
// exactly geomipmapping's level-l surface (client/lod/geomipmap.h), and its vertices morph
// toward level l + 1 and adapt their sides to a coarser neighbour by the same rules (a block is
// a patch at local level 0 whose local level 1 is the next clipmap level).
//
// Errors (ClipmapErrorPyramid): delta_l of a block is a bound on |height - level-l surface|
// over its mip-0 samples. Levels up to `exact_levels` are exact (every mip-0 sample checked).
// Above, delta_l = max over the children of delta_(l-1) plus the largest |level-(l-1) sample -
// level-l surface| over the block's level-(l-1) samples: the triangle inequality, since the
// difference of two nested union-jack surfaces is linear on the finer triangles. That costs
// (2C + 1)^2 samples of mip l - 1 per block, so a stamp's update stays small at every level.
//
// Selection: every block of the coarsest level inside its region is a root; a block is split
// while its delta exceeds what the budget allows where it is on screen (tau / k, k the pixels
// a vertical meter moves at worst over the block's box: lod/projected_error.h) and its
// children lie in the finer level's region, the largest error first, so that a cap on the
// blocks drawn leaves the smallest largest error. The tree
// is then made restricted (a leaf's neighbours are at most one level coarser), so a side is
// either plain or a fan toward the coarser neighbour: no crack, no T-junction. A leaf morphs
// toward its parent's surface exactly as far as the budget allows, (1 - m) delta_l + m
// delta_(l+1) = tau / k, so it appears at m = 1 (the parent's surface) and nothing pops.
// Regions must nest (a level's region inside the next one's, with two blocks to spare), as
// clipmap levels centred on the camera do; a split the restriction needs outside a region is
// counted in `unrestricted` and would leave a crack.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "client/lod/geomipmap.h"
#include "client/lod/mesh_check.h"
#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam::lod {

struct ClipmapBlockGrid {
  int32_t block_size = 17;  // vertices per side, 2^k + 1
  int32_t levels = 1;       // clipmap levels 0..levels-1
  int64_t width = 0, height = 0;

  // Errors: block_size not 2^k + 1 with 2 <= k <= 6, levels not 1..24, an empty world.
  static Result<ClipmapBlockGrid> make(int64_t width, int64_t height, int32_t block_size, int32_t levels);
  int32_t cells() const { return block_size - 1; }
  int64_t span(int32_t l) const { return int64_t(cells()) << l; }  // mip-0 samples per block side
  // Blocks per row / column at level l that hold a world sample.
  int32_t blocks_x(int32_t l) const { return int32_t((width - 1 + span(l) - 1) / span(l)); }
  int32_t blocks_y(int32_t l) const { return int32_t((height - 1 + span(l) - 1) / span(l)); }
  // The block's mip-0 samples, its border included.
  RectI block_rect(int32_t l, int64_t bx, int64_t by) const {
    return {bx * span(l), by * span(l), bx * span(l) + span(l) + 1, by * span(l) + span(l) + 1};
  }
  // The patch grid every block is drawn with (one patch of block_size).
  GeomipmapGrid patch_grid() const;
};

// Reads mip-`mip` samples of `rect` (that mip's grid, clamped at the world's edge) row-major.
using MipReader = std::function<void(int32_t mip, const RectI& rect, std::span<uint16_t> out)>;

struct ClipmapBlockId {
  int32_t level = 0, bx = 0, by = 0;
  bool operator==(const ClipmapBlockId&) const = default;
  auto operator<=>(const ClipmapBlockId&) const = default;
};

// The blocks of level l whose vertices lie in `region` (level samples, half-open) and under the
// coarsest level's blocks: the blocks the selection may use there (block coordinates, half-open).
RectI blocks_inside(const ClipmapBlockGrid& grid, int32_t l, const RectI& region);

// Block errors kept for a window of blocks per level. compute() windows the whole world (the
// `lod` suite, tests); a viewer's windows follow its level regions (move_windows), so memory and
// work follow the regions and never the world's size: a 131 km world costs what a 4 km one does.
// A block whose children lie outside the finer window takes the level-(l-1) samples as the
// finest there (none finer can be drawn there: the selection splits a block only into children
// inside the finer region), so a windowed bound equals the whole world's wherever the finer
// windows hold the block's subtree.
class ClipmapErrorPyramid {
 public:
  static ClipmapErrorPyramid compute(const ClipmapBlockGrid& grid, const MipReader& read,
                                     int32_t exact_levels = 3);
  // An empty pyramid for move_windows().
  static ClipmapErrorPyramid windowed(const ClipmapBlockGrid& grid, int32_t exact_levels = 3);
  // Moves level l's window to windows[l] (block coordinates, clipped to the level's blocks),
  // finest level first: entries that stay and whose subtree the finer windows still hold the same
  // are kept; the others are computed. Returns the blocks computed. Windows must nest as level
  // regions centred on the camera do (blocks_inside of each level's region).
  int64_t move_windows(const ClipmapBlockGrid& grid, const MipReader& read, std::span<const RectI> windows);
  // Recomputes every block (all levels) in the windows holding a sample of `changed` (mip-0
  // samples), finest first; returns them.
  std::vector<ClipmapBlockId> update(const ClipmapBlockGrid& grid, const MipReader& read,
                                     const RectI& changed);
  // Height units; level 0 is 0; a parent's is at least its children's. 0 outside the windows.
  float error(int32_t l, int64_t bx, int64_t by) const;
  uint16_t min_height(int32_t l, int64_t bx, int64_t by) const;
  uint16_t max_height(int32_t l, int64_t bx, int64_t by) const;
  // Level l's window (block coordinates).
  RectI window(int32_t l) const { return size_t(l) < level_.size() ? level_[size_t(l)].blocks : RectI{}; }
  int32_t exact_levels() const { return exact_levels_; }
  size_t bytes() const;

 private:
  struct Entry {
    float error = 0;
    uint16_t lo = 0, hi = 0;
  };
  struct Level {
    RectI blocks;                // the window, block coordinates
    std::vector<Entry> entries;  // row-major over the window
  };
  const Entry* find(int32_t l, int64_t bx, int64_t by) const;
  void compute_block(const ClipmapBlockGrid& grid, const MipReader& read, int32_t l, int64_t bx, int64_t by);
  int32_t exact_levels_ = 0;
  std::vector<Level> level_;
  std::vector<uint16_t> scratch_;
};

// A drawn block: its level and position, and its patch state (level 0 with morph toward the
// next clipmap level; side level 1 where the neighbour is one clipmap level coarser).
struct ClipmapBlock {
  ClipmapBlockId id;
  PatchLod lod;
};

struct ErrorClipmapSelectStats {
  int64_t blocks_tested = 0;
  int64_t split = 0;
  int64_t forced = 0;         // split only to keep the tree restricted
  int64_t held_back = 0;      // wanted a split its finer level's region could not give
  int64_t unrestricted = 0;   // a restriction split outside a region: a crack (regions too small)
  double tolerance_px = 0;    // the budget the blocks meet: the view's, or more where max_blocks bound
  bool budget_bound = false;  // max_blocks stopped a split the view's budget asked for
};

struct ErrorClipmapSelection {
  std::vector<ClipmapBlock> blocks;  // every leaf, finest level first, then row order
  RectI covered;                     // the roots' mip-0 samples (vertex positions, half-open)
  ErrorClipmapSelectStats stats;
};

// Whether a block is worth splitting at all (a frustum test): blocks it rejects stay leaves.
using BlockFilter = std::function<bool(int32_t level, int64_t bx, int64_t by)>;

// Chooses the blocks for the view. `regions[l]`: the level-l samples level l holds (half-open,
// its grid); a block is used only inside its level's region. `morph` false: leaves are drawn
// at their own level (no geomorphing). `split_only` (if set): the blocks the view draws;
// blocks it rejects are not split for the budget (the restriction may still split them).
// `max_blocks` (0: no limit): the most drawn leaves the budget's splits may make, blocks
// split in the order of the error they show; where it binds, the budget rises to the error of
// the first block left whole (stats.tolerance_px), and the morphs blend for that. The
// restriction's splits come on top.
ErrorClipmapSelection select_error_clipmap(const ClipmapBlockGrid& grid, const ClipmapErrorPyramid& errors,
                                           const HeightScale& scale, const LodView& view,
                                           std::span<const RectI> regions, bool morph = true,
                                           const BlockFilter& split_only = {}, int64_t max_blocks = 0);

// The height a block's local vertex (lx, ly) is drawn at, heights from mip 0.
float block_vertex_height(const ClipmapBlockGrid& grid, const HeightGrid& heights, const ClipmapBlock& block,
                          int32_t lx, int32_t ly);

// CPU replica of the selection (mip-0 sample coordinates), for lod::check_watertight over
// `covered`; and the drawn surface (height units) at every sample of `covered`, row-major (a
// vertex past the world's last sample drawn at it, as the renderer draws it).
std::vector<lod::ReplicaTriangle> replicate(const ClipmapBlockGrid& grid, const ErrorClipmapSelection& sel);
std::vector<float> displayed_surface(const ClipmapBlockGrid& grid, const HeightGrid& heights,
                                     const ErrorClipmapSelection& sel);
int64_t triangle_count(const ClipmapBlockGrid& grid, const ErrorClipmapSelection& sel);

}  // namespace loam::lod
