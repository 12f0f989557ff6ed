// Geomipmapping (de Boer 2000; Wagner's vertex-shader geomorphing, ShaderX2 2003) as pure
// logic: the patch grid, each patch's maximum vertical error per level, the level and morph
// factor a camera needs for a screen-space error budget, and the triangles of a patch whose
// borders adapt to coarser neighbours. No GL: the `lod` suite's renderer
// (bench/lod/geomipmap_renderer.h) draws what this decides, and the tests check it on a CPU
// replica (watertight, geomorph, error bound).
//
// Patches: square blocks of patch_size = 2^k + 1 vertices (17, 33, 65) sharing their border
// samples, so patch (px, py) covers mip-0 samples [px * c, px * c + c] x [py * c, py * c + c],
// c = patch_size - 1. Level l spaces vertices 2^l samples (l = 0..k; level k is two
// triangles). Cells split in the union-jack pattern (every diagonal of a 2s block points at the
// block's centre), which nests: a coarser level's triangles are unions of finer ones, so a
// surface blended between two levels stays piecewise linear on the finer triangles.
//
// The error of level l over a patch (de Boer's delta) is the largest |height - level-l
// surface| over the patch's samples, made non-decreasing in l. A camera at distance d from the
// patch's bounding box sees it as at most delta * K / d pixels (K = viewport height / (2 tan
// (fov_y / 2))), so the coarsest level within the budget tau is chosen, and the morph factor
// blends it toward the next coarser level exactly as far as the budget allows:
// (1 - m) delta_l + m delta_(l+1) = tau d / K. m reaches 1 just where level l + 1 takes
// over, so a level change moves no vertex (no pop).
//
// Borders: each side of a patch uses the coarser of its own and its neighbour's level. Where
// the neighbour is one level coarser, the row of cells along the side drops the side's odd
// vertices: each pair of cells becomes a fan, exactly the union-jack triangles once those
// vertices lie on the coarser edge, so a neighbour's level change moves nothing. Two or more
// levels coarser, the row is one strip zipped between the side's vertices and the inner line.
// No T-junction, no crack, whatever the level difference (corner cells split along their
// union-jack diagonal, between the two sides). A side's
// morph is the largest morph among the patches at the side's level, so both patches give its
// vertices the same heights. With every side at the patch's own level the mesh is the plain
// grid, whose error the patch's delta bounds exactly.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "client/lod/mesh_check.h"
#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam::lod {

// Mip-0 heights, row-major; a read outside clamps to the nearest edge sample.
struct HeightGrid {
  std::span<const uint16_t> samples;
  int64_t width = 0, height = 0;
  uint16_t at(int64_t x, int64_t y) const;
};

// Converts height units and sample spacing to meters.
struct HeightScale {
  double meters_per_sample = 1.0;
  double meters_per_unit = 1.0;
  double height_offset = 0.0;
  double meters(uint16_t h) const { return height_offset + double(h) * meters_per_unit; }
};

struct GeomipmapGrid {
  int32_t patch_size = 17;  // vertices per side
  int32_t levels = 5;       // log2(patch_size - 1) + 1
  int32_t patches_x = 0, patches_y = 0;
  int64_t width = 0, height = 0;  // the world's samples

  // Errors: patch_size not 2^k + 1 with 2 <= k <= 8, or an empty world.
  static Result<GeomipmapGrid> make(int64_t width, int64_t height, int32_t patch_size);
  int32_t cells() const { return patch_size - 1; }
  int32_t patch_count() const { return patches_x * patches_y; }
  // The patch's samples, its border included: [x0, x1) x [y0, y1) with x1 = x0 + cells + 1.
  RectI patch_rect(int32_t px, int32_t py) const;
  // Every vertex position the patches cover: [0, patches_x * cells] x [0, patches_y * cells].
  RectI covered() const;
};

// Per patch and level, the maximum vertical error (height units) and the height bounds.
class GeomipmapErrors {
 public:
  static GeomipmapErrors compute(const GeomipmapGrid& grid, const HeightGrid& heights);
  // Recomputes the patches whose samples `changed` (mip-0 samples) touches and returns them,
  // (px, py) in row order: what a stamp costs the error bounds.
  std::vector<std::array<int32_t, 2>> update(const GeomipmapGrid& grid, const HeightGrid& heights,
                                             const RectI& changed);
  // Non-decreasing in level; level 0 is 0.
  float error(int32_t px, int32_t py, int32_t level) const {
    return errors_[(size_t(py) * size_t(patches_x_) + size_t(px)) * size_t(levels_) + size_t(level)];
  }
  uint16_t min_height(int32_t px, int32_t py) const { return bounds_[index(px, py)][0]; }
  uint16_t max_height(int32_t px, int32_t py) const { return bounds_[index(px, py)][1]; }

 private:
  size_t index(int32_t px, int32_t py) const { return size_t(py) * size_t(patches_x_) + size_t(px); }
  void compute_patch(const GeomipmapGrid& grid, const HeightGrid& heights, int32_t px, int32_t py);
  int32_t patches_x_ = 0, levels_ = 0;
  std::vector<float> errors_;
  std::vector<std::array<uint16_t, 2>> bounds_;
};

// What a camera needs: its position (world meters: x east along +gx, y along +gy, z up) and
// the pixels one meter spans at one meter's distance.
struct LodView {
  double x = 0, y = 0, z = 0;
  double pixels_per_radian = 1000.0;  // viewport height / (2 tan(fov_y / 2))
  double tolerance_px = 1.0;
  // Where the view looks (lod/projected_error.h: set_view_axes): unit axes in the world frame
  // and the screen's half extents as tangents. half_tan_x 0: unknown, a block's screen error is
  // bounded by its distance alone (the schemes of the `lod` suite's comparison).
  std::array<double, 3> forward{0, 0, 0}, right{0, 0, 0}, up{0, 0, 0};
  double half_tan_x = 0, half_tan_y = 0;
};
// The pixels_per_radian of a perspective view.
double pixels_per_radian(int32_t viewport_height, double fov_y_degrees);

enum Side : int32_t { kSideTop = 0, kSideRight = 1, kSideBottom = 2, kSideLeft = 3 };  // -y, +x, +y, -x

struct PatchLod {
  int8_t level = 0;
  float morph = 0;                     // toward level + 1
  std::array<int8_t, 4> edge_level{};  // per Side: max(own, neighbour's)
  std::array<float, 4> edge_morph{};   // per Side: toward edge_level + 1
};

// Level and morph of every patch (row order) for the view, then the sides (assign_sides).
std::vector<PatchLod> select_lods(const GeomipmapGrid& grid, const GeomipmapErrors& errors,
                                  const HeightScale& scale, const LodView& view, bool morph = true);

// Sets every patch's side levels and morphs from the patches' own (row order).
void assign_sides(const GeomipmapGrid& grid, std::vector<PatchLod>& lods);

// Leitao & Carmo's tiled blocks with skirts instead of index updates: every side at the patch's
// own level and morph, so no patch reads its neighbours (the mesh has cracks where levels
// differ, which the skirts hide).
void assign_own_sides(std::vector<PatchLod>& lods);

// Per patch (row order), the depth (height units) its skirts hang below its sides: at least the
// largest gap along any side between its drawn surface and its neighbour's, which is at most
// the sum of the two patches' errors at the levels they draw (the next coarser one while
// morphing). 0 for a patch with no neighbour.
std::vector<float> skirt_depths(const GeomipmapGrid& grid, const GeomipmapErrors& errors,
                                const std::vector<PatchLod>& lods);

// The skirt of a patch at `level`: for each side, quads from the side's vertices (spacing 2^level)
// down to their lowered copies, vertex id patch_size^2 + side * patch_size + t for the copy of
// the side's vertex at position t along it (x for top and bottom, y for left and right).
std::vector<std::array<uint16_t, 3>> skirt_triangles(const GeomipmapGrid& grid, int32_t level);

// The drawn height (height units) along a side of a patch at every sample t = 0..cells: the
// surface's edge, linear between the side's vertices (for the skirt tests).
std::vector<float> side_profile(const GeomipmapGrid& grid, const HeightGrid& heights, int32_t px, int32_t py,
                                const PatchLod& lod, int32_t side);

// The triangles of a patch at `level` with sides at `edge_level`, as local vertex indices
// (y * patch_size + x), counter-clockwise in (x, y) sample coordinates (positive area with y
// along +gy). Deterministic: the renderer caches index buffers by (level, edge levels).
std::vector<std::array<uint16_t, 3>> patch_triangles(const GeomipmapGrid& grid, int32_t level,
                                                     const std::array<int8_t, 4>& edge_level);

// The height a vertex is drawn at (height units, fractional while morphing): local vertex
// (lx, ly) of patch (px, py) under `lod`. The morph target is the next coarser level's
// surface; a border vertex uses its side's level and morph.
float displayed_height(const GeomipmapGrid& grid, const HeightGrid& heights, int32_t px, int32_t py,
                       const PatchLod& lod, int32_t lx, int32_t ly);

// The rule of displayed_height for a patch of `cells` cells per side and `levels` levels whose
// local vertex heights come from any function h(lx, ly) (a clipmap level's samples, say).
float morphed_vertex_height(int32_t cells, int32_t levels, const PatchLod& lod, int32_t lx, int32_t ly,
                            const std::function<double(int32_t, int32_t)>& h);

// Whether the level cell with lower corner (x, y) (non-negative multiples of s) splits along
// (x, y)-(x + s, y + s) rather than (x + s, y)-(x, y + s): the union-jack pattern, every
// diagonal of a 2s block pointing at the block's centre. It nests: each diagonal of level l + 1
// is two of level l, so a coarser level's triangles are unions of finer ones at every level.
inline bool union_jack_main_diagonal(int64_t x, int64_t y, int64_t s) {
  return (((x / s) ^ (y / s)) & 1) == 0;
}

// The union-jack surface of a cell at fraction (fx, fy) in [0, 1] from its corner heights.
double union_jack_surface(double h00, double h10, double h01, double h11, double fx, double fy,
                          bool main_diagonal);

// Distance from a point to a box.
double box_distance(double x, double y, double z, const std::array<double, 3>& lo,
                    const std::array<double, 3>& hi);

// Writes a triangle's linear interpolation of `z` at every sample it covers (edges included) into
// `out`, rows of cov.width() from cov's low corner; the replicas' displayed_surface.
void rasterize_heights(const std::array<int64_t, 3>& x, const std::array<int64_t, 3>& y,
                       const std::array<double, 3>& z, const RectI& cov, std::vector<float>& out);

// CPU replica: every triangle drawn for `lods`, in mip-0 sample coordinates (for
// lod::check_watertight over grid.covered()).
std::vector<lod::ReplicaTriangle> replicate(const GeomipmapGrid& grid, const std::vector<PatchLod>& lods);

// The drawn surface's height (height units) at every sample of grid.covered(), row-major:
// each triangle's displayed vertex heights interpolated at the samples it covers.
std::vector<float> displayed_surface(const GeomipmapGrid& grid, const HeightGrid& heights,
                                     const std::vector<PatchLod>& lods);

// Non-degenerate triangles drawn for `lods`.
int64_t triangle_count(const GeomipmapGrid& grid, const std::vector<PatchLod>& lods);

}  // namespace loam::lod
