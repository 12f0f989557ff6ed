#include "client/lod/clipmap_mesh.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace loam::lod {

namespace {

struct Builder {
  int32_t n;
  std::vector<uint32_t>& out;
  uint32_t id(int32_t x, int32_t y) const { return uint32_t(y) * uint32_t(n) + uint32_t(x); }
  // Quads [qx0, qx1) x [qy0, qy1) that `keep` accepts, each split along (x, y)-(x+1, y+1), CCW
  // with y up.
  template <typename Keep>
  Piece quads(PieceKind kind, int32_t qx0, int32_t qy0, int32_t qx1, int32_t qy1, Keep keep) {
    Piece p{kind, uint32_t(out.size()), 0, qx1, qy1, qx0, qy0};
    for (int32_t y = qy0; y < qy1; ++y) {
      for (int32_t x = qx0; x < qx1; ++x) {
        if (!keep(x, y)) continue;
        const uint32_t a = id(x, y), b = id(x + 1, y), c = id(x + 1, y + 1), d = id(x, y + 1);
        out.insert(out.end(), {a, b, c, a, c, d});
        p.x0 = std::min(p.x0, x), p.y0 = std::min(p.y0, y);
        p.x1 = std::max(p.x1, x + 1), p.y1 = std::max(p.y1, y + 1);
      }
    }
    p.index_count = uint32_t(out.size()) - p.first_index;
    return p;
  }
  Piece quads(PieceKind kind, int32_t qx0, int32_t qy0, int32_t qx1, int32_t qy1) {
    return quads(kind, qx0, qy0, qx1, qy1, [](int32_t, int32_t) { return true; });
  }
};

}  // namespace

Result<ClipmapMesh> ClipmapMesh::build(int32_t n) {
  if (n < 7 || n > 1023 || ((n + 1) & n) != 0) {
    return make_error(ErrorCode::kInvalidArgument, "clipmap.n", "must be 2^k - 1 between 7 and 1023");
  }
  ClipmapMesh mesh;
  mesh.n_ = n;
  const int32_t m = (n + 1) / 4;
  Builder b{n, mesh.indices_};
  // Quad segments along one side: four blocks of m - 1 quads and the 2-quad fix-up between.
  const int32_t seg[6] = {0, m - 1, 2 * m - 2, 2 * m, 3 * m - 1, 4 * m - 2};
  for (int sy = 0; sy < 5; ++sy) {
    for (int sx = 0; sx < 5; ++sx) {
      const bool outer = sx == 0 || sx == 4 || sy == 0 || sy == 4;
      if (!outer || (sx == 2 && sy == 2)) continue;
      const bool fixup = sx == 2 || sy == 2;
      mesh.ring_.push_back(
          b.quads(fixup ? PieceKind::kFixup : PieceKind::kBlock, seg[sx], seg[sy], seg[sx + 1], seg[sy + 1]));
    }
  }
  // Blocks first, then fix-ups (the renderer draws them the same way; the order only helps
  // reading a capture).
  std::stable_partition(mesh.ring_.begin(), mesh.ring_.end(),
                        [](const Piece& p) { return p.kind == PieceKind::kBlock; });
  for (const Piece& p : mesh.ring_) mesh.ring_indices_ += p.index_count;
  const int32_t h0 = m - 1, h1 = 3 * m - 1;  // the hole, in quads
  for (int v = 0; v < 4; ++v) {
    const int32_t col = (v & 1) ? h1 - 1 : h0;
    const int32_t row = (v & 2) ? h1 - 1 : h0;
    mesh.trims_[size_t(v)] =
        b.quads(PieceKind::kTrim, h0, h0, h1, h1, [&](int32_t x, int32_t y) { return x == col || y == row; });
  }
  mesh.fill_ = b.quads(PieceKind::kFill, h0, h0, h1, h1);
  // Boundary loop counter-clockwise; each side's triangles run clockwise so their edges pair
  // with the level's own (CCW) triangles inside and the coarser level's outside.
  Piece& d = mesh.degenerate_;
  d = Piece{PieceKind::kDegenerate, uint32_t(mesh.indices_.size()), 0, 0, 0, n - 1, n - 1};
  const int32_t corners[5][2] = {{0, 0}, {n - 1, 0}, {n - 1, n - 1}, {0, n - 1}, {0, 0}};
  for (int side = 0; side < 4; ++side) {
    const int32_t dx = (corners[side + 1][0] - corners[side][0]) / (n - 1);
    const int32_t dy = (corners[side + 1][1] - corners[side][1]) / (n - 1);
    for (int32_t i = 0; i + 2 <= n - 1; i += 2) {
      const int32_t x = corners[side][0], y = corners[side][1];
      mesh.indices_.insert(mesh.indices_.end(),
                           {b.id(x + (i + 2) * dx, y + (i + 2) * dy),
                            b.id(x + (i + 1) * dx, y + (i + 1) * dy), b.id(x + i * dx, y + i * dy)});
    }
  }
  d.index_count = uint32_t(mesh.indices_.size()) - d.first_index;
  return mesh;
}

std::vector<LevelPlacement> place_levels(int32_t n, int32_t levels, double cam_x, double cam_y) {
  std::vector<LevelPlacement> out;
  const int32_t m = (n + 1) / 4;
  const double half = double(n - 1) / 2.0;
  // Nearest even origin, not floor: floor would leave the camera up to 2 samples off centre
  // on one side, and the geomorph band assumes at most 1.
  auto snap0 = [&](double c) { return 2 * int64_t(std::floor((c - half) / 2.0 + 0.5)); };
  LevelPlacement p;
  p.level = 0;
  p.origin_x = snap0(cam_x);
  p.origin_y = snap0(cam_y);
  out.push_back(p);
  for (int32_t l = 1; l < levels; ++l) {
    const int64_t s = int64_t(1) << l;
    LevelPlacement q;
    q.level = l;
    const int64_t ax = out.back().origin_x - (m - 1) * s, ay = out.back().origin_y - (m - 1) * s;
    const bool fine_low_x = floor_mod(ax, 2 * s) == 0, fine_low_y = floor_mod(ay, 2 * s) == 0;
    q.origin_x = fine_low_x ? ax : ax - s;
    q.origin_y = fine_low_y ? ay : ay - s;
    // The finer level at the hole's low side leaves the trim at its high side.
    q.trim_variant = (fine_low_x ? 1 : 0) | (fine_low_y ? 2 : 0);
    out.push_back(q);
  }
  return out;
}

int32_t morph_band(int32_t n) {
  const int32_t m = (n + 1) / 4;
  if (m - 3 < 1) return 0;
  return std::min(m - 3, std::max(1, (n + 1) / 10));
}

double morph_alpha(int32_t n, double x, double y, double vx, double vy) {
  if (x <= 0 || y <= 0 || x >= n - 1 || y >= n - 1) return 1.0;
  const int32_t w = morph_band(n);
  if (w == 0) return 0.0;
  const int32_t m = (n + 1) / 4;
  const double d = std::max(std::abs(x - vx), std::abs(y - vy));
  return std::clamp((d - double(2 * m - 2 - w)) / double(w), 0.0, 1.0);
}

std::vector<RectI> toroidal_strips(std::optional<std::array<int64_t, 2>> old, std::array<int64_t, 2> now,
                                   int64_t size) {
  const auto [rx, ry] = now;
  const RectI next{rx, ry, rx + size, ry + size};
  if (!old || std::abs(rx - (*old)[0]) >= size || std::abs(ry - (*old)[1]) >= size) return {next};
  const RectI prev{(*old)[0], (*old)[1], (*old)[0] + size, (*old)[1] + size};
  std::vector<RectI> out;
  if (rx > prev.x0) out.push_back({prev.x1, ry, next.x1, next.y1});
  if (rx < prev.x0) out.push_back({rx, ry, prev.x0, next.y1});
  const int64_t sx0 = std::max(rx, prev.x0), sx1 = std::min(next.x1, prev.x1);
  if (ry > prev.y0) out.push_back({sx0, prev.y1, sx1, next.y1});
  if (ry < prev.y0) out.push_back({sx0, ry, sx1, prev.y0});
  return out;
}

int32_t levels_for_view_distance(int32_t n, double meters_per_sample, double view_distance) {
  for (int32_t l = 1; l < kMaxClipmapLevels; ++l) {
    // The camera may sit a sample off a level's centre: count one sample less than half.
    const double reach = (double(n - 1) / 2.0 - 1.0) * double(int64_t(1) << (l - 1)) * meters_per_sample;
    if (reach >= view_distance) return l;
  }
  return kMaxClipmapLevels;
}

std::vector<ReplicaTriangle> replicate(const ClipmapMesh& mesh, const std::vector<LevelPlacement>& levels,
                                       bool with_degenerates) {
  std::vector<ReplicaTriangle> out;
  const int32_t n = mesh.n();
  const auto& idx = mesh.indices();
  for (size_t li = 0; li < levels.size(); ++li) {
    const LevelPlacement& lp = levels[li];
    std::vector<const Piece*> pieces;
    for (const Piece& p : mesh.ring()) pieces.push_back(&p);
    pieces.push_back(lp.trim_variant < 0 ? &mesh.fill() : &mesh.trim(lp.trim_variant));
    if (with_degenerates && li + 1 < levels.size()) pieces.push_back(&mesh.degenerate());
    for (const Piece* p : pieces) {
      for (uint32_t i = p->first_index; i < p->first_index + p->index_count; i += 3) {
        ReplicaTriangle t;
        t.degenerate = p->kind == PieceKind::kDegenerate;
        for (int k = 0; k < 3; ++k) {
          const uint32_t v = idx[i + uint32_t(k)];
          t.x[size_t(k)] = lp.origin_x + int64_t(v % uint32_t(n)) * lp.spacing();
          t.y[size_t(k)] = lp.origin_y + int64_t(v / uint32_t(n)) * lp.spacing();
        }
        out.push_back(t);
      }
    }
  }
  return out;
}

}  // namespace loam::lod
