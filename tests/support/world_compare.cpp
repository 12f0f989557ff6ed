#include "tests/support/world_compare.h"

#include <algorithm>

#include "protocol/geometry.h"
#include "protocol/world_layers.h"

namespace loam::test {

int64_t sample_mismatches(const World& a, const World& b, Layer layer) {
  return visit_layer(layer, [&](auto row) {
    using R = decltype(row);
    const RectI r = R::sample_rect(a.params());
    int64_t n = 0;
    for (int64_t y = r.y0; y < r.y1; ++y) {
      const RectI line{r.x0, y, r.x1, y + 1};
      const auto sa = read_rect<R>(a, line), sb = read_rect<R>(b, line);
      for (size_t i = 0; i < sa.size(); ++i) n += sa[i] != sb[i];
    }
    return n;
  });
}

std::optional<std::string> first_tile_difference(const World& a, const World& b, TileComparison what) {
  const auto state_differs = [&](const TileCoord& c) -> std::optional<std::string> {
    const TileState sa = a.tile_state(c), sb = b.tile_state(c);
    if (sa.hash != sb.hash) return to_string(c) + ": hashes differ";
    if (what.versions && sa.version != sb.version)
      return to_string(c) + ": versions differ (" + std::to_string(sa.version) + " and " +
             std::to_string(sb.version) + ")";
    return std::nullopt;
  };
  for (int32_t m = 0; m < a.params().mip_count(); ++m) {
    const RectI t = a.params().tile_range(m);
    for (int64_t ty = t.y0; ty < t.y1; ++ty) {
      for (int64_t tx = t.x0; tx < t.x1; ++tx) {
        const auto sa = a.coarse_tile(m, int32_t(tx), int32_t(ty));
        const auto sb = b.coarse_tile(m, int32_t(tx), int32_t(ty));
        const TileCoord c{Layer::kCoarse, uint8_t(m), int32_t(tx), int32_t(ty)};
        if (!std::equal(sa.begin(), sa.end(), sb.begin(), sb.end())) return to_string(c) + ": samples differ";
        if (auto d = state_differs(c)) return d;
      }
    }
  }
  if (!what.detail) return std::nullopt;
  const RectI d = tiles_overlapping(a.params().detail_sample_rect());
  for (int64_t ty = d.y0; ty < d.y1; ++ty) {
    for (int64_t tx = d.x0; tx < d.x1; ++tx) {
      const TileCoord c{Layer::kDetail, 0, int32_t(tx), int32_t(ty)};
      const auto sa = a.detail_tile(int32_t(tx), int32_t(ty));
      const auto sb = b.detail_tile(int32_t(tx), int32_t(ty));
      if (!std::equal(sa.begin(), sa.end(), sb.begin(), sb.end())) return to_string(c) + ": samples differ";
      if (auto diff = state_differs(c)) return diff;
    }
  }
  return std::nullopt;
}

}  // namespace loam::test
