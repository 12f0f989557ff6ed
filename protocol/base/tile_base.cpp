#include "protocol/base/tile_base.h"

#include <xxhash.h>

#include <algorithm>
#include <cassert>
#include <cstdio>
#include <vector>

namespace loam {

void FillBase::coarse_tile(int32_t, int32_t, int32_t, std::span<uint16_t> out) const {
  std::fill(out.begin(), out.end(), value_);
}

uint64_t FillBase::identity() const {
  const uint64_t record[2] = {0x6c6c69666d616f6cull /* "loamfill" */, value_};
  return XXH3_64bits(record, sizeof record);
}

std::string FillBase::describe() const { return "fill " + std::to_string(value_); }

RefinedTileBase::RefinedTileBase(RefinedBase refined, const WorldParams& params)
    : refined_(std::move(refined)), samples_(params.sample_rect()) {
  const uint64_t record[3] = {0x64656e6966656d6full /* "omefined" */, refined_.identity(),
                              uint64_t(samples_.x0) ^ (uint64_t(samples_.y0) << 32)};
  identity_ = XXH3_64bits(record, sizeof record);
}

Result<std::shared_ptr<const RefinedTileBase>> RefinedTileBase::create(RefinedBase refined,
                                                                       const WorldParams& params) {
  LOAM_TRY(params.validate());
  const RectI r = params.sample_rect();
  if (r.x0 < 0 || r.y0 < 0 || r.x1 > refined.width() || r.y1 > refined.height())
    return make_error(ErrorCode::kInvalidArgument, "base.refined",
                      "the world's samples reach outside the refined extent of " +
                          std::to_string(refined.width()) + "x" + std::to_string(refined.height()));
  return std::shared_ptr<const RefinedTileBase>(new RefinedTileBase(std::move(refined), params));
}

void RefinedTileBase::coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const {
  assert(out.size() == size_t(kTileSamples));
  const RectI t = tile_rect(tx, ty);
  // Mip-0 position of each row and column, clamped to the world; which are inside it.
  int64_t cx[kTileSize], cy[kTileSize];
  int64_t in_x0 = kTileSize, in_x1 = 0, in_y0 = kTileSize, in_y1 = 0;
  for (int32_t k = 0; k < kTileSize; ++k) {
    const int64_t x = (t.x0 + k) << mip, y = (t.y0 + k) << mip;
    cx[k] = std::clamp(x, samples_.x0, samples_.x1 - 1);
    cy[k] = std::clamp(y, samples_.y0, samples_.y1 - 1);
    if (cx[k] == x) in_x0 = std::min<int64_t>(in_x0, k), in_x1 = std::max<int64_t>(in_x1, k + 1);
    if (cy[k] == y) in_y0 = std::min<int64_t>(in_y0, k), in_y1 = std::max<int64_t>(in_y1, k + 1);
  }
  // The part inside the world is one rect of the mip.
  if (in_x1 > in_x0 && in_y1 > in_y0) {
    std::vector<uint16_t> inner(size_t((in_x1 - in_x0) * (in_y1 - in_y0)));
    refined_.generate(mip, {t.x0 + in_x0, t.y0 + in_y0, t.x0 + in_x1, t.y0 + in_y1}, inner);
    for (int64_t y = in_y0; y < in_y1; ++y)
      std::copy_n(inner.data() + (y - in_y0) * (in_x1 - in_x0), in_x1 - in_x0,
                  out.data() + y * kTileSize + in_x0);
  }
  // Samples beyond the edge repeat edge samples of mip 0: one at a time (edge tiles only),
  // and rows beyond the edge copy the first such row.
  const auto sample0 = [&](int64_t x, int64_t y) {
    uint16_t v = 0;
    refined_.generate(0, {x, y, x + 1, y + 1}, std::span<uint16_t>(&v, 1));
    return v;
  };
  int64_t done_row = -1;
  for (int64_t y = 0; y < kTileSize; ++y) {
    const bool row_in = y >= in_y0 && y < in_y1;
    uint16_t* row = out.data() + y * kTileSize;
    if (!row_in && done_row >= 0 && cy[done_row] == cy[y]) {
      std::copy_n(out.data() + done_row * kTileSize, kTileSize, row);
      continue;
    }
    for (int64_t x = 0; x < kTileSize; ++x) {
      if (row_in && x >= in_x0 && x < in_x1) continue;
      row[x] = sample0(cx[x], cy[y]);
    }
    if (!row_in) done_row = y;
  }
}

std::string RefinedTileBase::describe() const {
  char id[24];
  std::snprintf(id, sizeof id, "%016llx", (unsigned long long)refined_.identity());
  return "refined " + std::to_string(refined_.source_width()) + "x" +
         std::to_string(refined_.source_height()) + " source x" +
         std::to_string(1 << refined_.params().levels) + " (" + id + ")";
}

}  // namespace loam
