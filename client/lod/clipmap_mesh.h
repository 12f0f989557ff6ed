// Geometry clipmap meshes on the CPU (no GL): the index buffers the renderer draws, where each
// level sits for a camera, the geomorph blend, and a world-space replica of all levels so tests
// can prove the mesh watertight without a GPU.
//
// Layout (after Asirvatham & Hoppe, "Terrain rendering using GPU-based geometry clipmaps"):
// every level is an n x n vertex grid (n = 2^k - 1) in its own units, level l having spacing
// 2^l mip-0 samples and reading mip l. Vertex (x, y) of a level is vertex id y * n + x, so one
// index buffer serves every level; the vertex shader derives (x, y) from gl_VertexID. Pieces:
//   - 12 blocks of m x m vertices (m = (n + 1) / 4) around the ring,
//   - 4 ring fix-ups (3 x m and m x 3) in the middle of each side,
//   - 4 variants of the interior trim: the one-quad-wide L between the hole (2m quads) and the
//     finer level (2m - 1 quads), on the side the finer level leaves free,
//   - the finest level's fill of the hole,
//   - zero-area triangles along the level's outer boundary, (v2i, v2i+1, v2i+2), that join the
//     level's fine boundary edges to the coarser level's edges (no T-junctions).
// Every quad is split along the same diagonal, (x, y)-(x+1, y+1), at every level; the geomorph
// target of a fine vertex is then exactly the coarser level's triangle surface there.
//
// Placement: the finest level's origin is snapped to even samples nearest to centering it on
// the camera; each coarser level's origin is the unique multiple of twice its spacing that puts
// the finer level 0 or 1 sample (its own spacing) past the hole's low corner. Every level's
// centre is then within one of its samples of the camera in x and y.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "client/lod/mesh_check.h"
#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam::lod {

inline constexpr int32_t kMaxClipmapLevels = 24;

enum class PieceKind : uint8_t { kBlock, kFixup, kTrim, kFill, kDegenerate };

// A range of the index buffer and the local vertex box it touches (inclusive), for culling.
struct Piece {
  PieceKind kind = PieceKind::kBlock;
  uint32_t first_index = 0;
  uint32_t index_count = 0;
  int32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

class ClipmapMesh {
 public:
  // n must be 2^k - 1 with 7 <= n <= 1023.
  static Result<ClipmapMesh> build(int32_t n);

  int32_t n() const { return n_; }
  int32_t m() const { return (n_ + 1) / 4; }
  const std::vector<uint32_t>& indices() const { return indices_; }
  // The 12 blocks then the 4 fix-ups: drawn by every level.
  const std::vector<Piece>& ring() const { return ring_; }
  // Interior trim; bit 0 of `variant`: trim column at the hole's high x, bit 1: row at high y.
  const Piece& trim(int variant) const { return trims_[size_t(variant & 3)]; }
  const Piece& fill() const { return fill_; }  // the finest level's hole
  const Piece& degenerate() const { return degenerate_; }
  // Non-degenerate triangles drawn per level (ring + trim, or ring + fill for the finest).
  int64_t triangles_per_level() const {
    return int64_t(ring_indices_) / 3 + int64_t(trims_[0].index_count) / 3;
  }

 private:
  ClipmapMesh() = default;
  int32_t n_ = 0;
  std::vector<uint32_t> indices_;
  std::vector<Piece> ring_;
  std::array<Piece, 4> trims_{};
  Piece fill_, degenerate_;
  uint32_t ring_indices_ = 0;
};

// Where one level sits: local vertex (x, y) is mip-0 sample (origin_x + x * 2^l, ...).
struct LevelPlacement {
  int32_t level = 0;  // also its mip and log2 of its spacing in mip-0 samples
  int64_t origin_x = 0, origin_y = 0;
  int trim_variant = -1;  // ClipmapMesh::trim variant; -1 for the finest level (fill)
  int64_t spacing() const { return int64_t(1) << level; }
  // Mip-0 samples covered by the level's vertices, half-open.
  RectI sample_rect(int32_t n) const {
    const int64_t e = int64_t(n - 1) * spacing() + 1;
    return {origin_x, origin_y, origin_x + e, origin_y + e};
  }
};

// Level placements, finest first, for a camera at (cam_x, cam_y) in mip-0 sample units.
std::vector<LevelPlacement> place_levels(int32_t n, int32_t levels, double cam_x, double cam_y);

// Width of the geomorph band in level samples (0: n too small for one, no morphing). The band
// ends at the outer boundary and starts outside the hole even with the camera one sample off
// centre, so a level is unmorphed where the finer level meets it.
int32_t morph_band(int32_t n);

// Geomorph blend (0: the level's own samples, 1: the coarser level's surface) of local vertex
// (x, y) for a viewer at level-local (vx, vy); the vertex shader computes the same. Vertices on
// the outer boundary are always 1.
double morph_alpha(int32_t n, double x, double y, double vx, double vy);

// Toroidal texture updates: a square region of `size` samples moved from `old` (its low corner;
// nullopt when nothing is loaded) to `now`. Returns the rects (region-grid samples) to load:
// the whole region after a jump of a full size or more, else the columns that entered over
// the full new height, then the rows that entered over the shared columns.
std::vector<RectI> toroidal_strips(std::optional<std::array<int64_t, 2>> old, std::array<int64_t, 2> now,
                                   int64_t size);

// The number of levels whose outermost extent reaches `view_distance` meters from the camera.
int32_t levels_for_view_distance(int32_t n, double meters_per_sample, double view_distance);

// --- CPU replica of what the renderer draws, in mip-0 sample coordinates ---
// Every triangle of every level for these placements, as the renderer draws them (degenerate
// boundary triangles of all but the outermost level unless `with_degenerates` is false).
std::vector<ReplicaTriangle> replicate(const ClipmapMesh& mesh, const std::vector<LevelPlacement>& levels,
                                       bool with_degenerates = true);

}  // namespace loam::lod
