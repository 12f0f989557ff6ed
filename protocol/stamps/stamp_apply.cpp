#include "protocol/stamps/stamp_apply.h"

#include <algorithm>
#include <vector>

#include "protocol/stamps/shockwave.h"
#include "protocol/stamps/stamp_kernel.h"
#include "protocol/stamps/stamp_kinds.h"
#include "protocol/world.h"
#include "protocol/world_layers.h"

namespace loam {

namespace {

// The reference per-tile loop: stamp_sample on every sample of the part of b.rect inside
// one tile; returns the changed rect.
template <typename T>
RectI apply_in_tile(const BakedStamp& b, T* tile, int64_t tx, int64_t ty) {
  const RectI part = b.rect.intersect(tile_rect(int32_t(tx), int32_t(ty)));
  RectI changed;
  for (int64_t y = part.y0; y < part.y1; ++y) {
    T* row = tile + (y - ty * kTileSize) * kTileSize - tx * kTileSize;
    int64_t cx0 = part.x1, cx1 = part.x0;
    for (int64_t x = part.x0; x < part.x1; ++x) {
      const int32_t old = row[x];
      const int32_t nv = stamp_sample(b, x, y, old);
      if (nv != old) {
        row[x] = T(nv);
        cx0 = std::min(cx0, x);
        cx1 = x + 1;
      }
    }
    if (cx1 > cx0) changed = changed.unite(RectI{cx0, y, cx1, y + 1});
  }
  return changed;
}

// Visits every tile the stamp's rect overlaps with `in_tile(tile_samples, tx, ty)` (which
// returns the changed rect), marks what changed dirty and returns the union. An absent detail
// tile is all zero: the kernel runs on a scratch copy, stored only if something changed.
template <typename InTile>
RectI walk_tiles(World& world, const BakedStamp& b, const InTile& in_tile) {
  const Layer layer = b.q.layer;
  return visit_layer(layer, [&](auto row) {
    using R = decltype(row);
    using Ops = LayerOps<R>;
    RectI touched;
    const RectI tiles = tiles_overlapping(b.rect);
    std::vector<typename R::Sample> scratch;
    for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
      for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
        RectI changed;
        if constexpr (R::kHasBase) {
          // Every tile of a layer with a base exists (generated where never edited).
          const auto tile = Ops::tile_mut(world, int32_t(tx), int32_t(ty));
          if (tile.empty()) continue;
          changed = in_tile(tile.data(), tx, ty);
        } else if (!Ops::tile(world, int32_t(tx), int32_t(ty)).empty()) {
          changed = in_tile(Ops::tile_mut(world, int32_t(tx), int32_t(ty)).data(), tx, ty);
        } else {
          scratch.assign(kTileSamples, 0);
          changed = in_tile(scratch.data(), tx, ty);
          if (!changed.empty()) {
            const auto tile = Ops::tile_mut(world, int32_t(tx), int32_t(ty));
            std::copy(scratch.begin(), scratch.end(), tile.begin());
          }
        }
        if (!changed.empty()) {
          world.mark_dirty(layer, changed);
          touched = touched.unite(changed);
        }
      }
    }
    return touched;
  });
}

}  // namespace

Result<RectI> apply_stamp_reference(World& world, const QuantizedStamp& q, const TextureRegistry* textures,
                                    const StampLimits& limits) {
  LOAM_TRY(check_quantized(q, world.params(), limits, textures));
  if (q.kind == StampKind::kShockwave) return apply_shockwave(world, q);
  auto baked = bake_stamp(q, world.params(), textures);
  LOAM_TRY(baked);
  BakedStamp& b = baked.value();
  if (stamp_kind(q.kind).needs_contact) footprint_contact(b, world);
  return walk_tiles(world, b,
                    [&](auto* tile, int64_t tx, int64_t ty) { return apply_in_tile(b, tile, tx, ty); });
}

Result<RectI> apply_stamp_with(World& world, const QuantizedStamp& q, FastIsa isa,
                               const TextureRegistry* textures, const StampLimits& limits) {
  LOAM_TRY(check_quantized(q, world.params(), limits, textures));
  if (q.kind == StampKind::kShockwave) return apply_shockwave(world, q);
  auto baked = bake_stamp(q, world.params(), textures);
  LOAM_TRY(baked);
  BakedStamp& b = baked.value();
  if (stamp_kind(q.kind).needs_contact) footprint_contact_fast(b, world);
  const FastStamp fast(b, isa);
  return walk_tiles(world, b,
                    [&](auto* tile, int64_t tx, int64_t ty) { return fast.apply_in_tile(tile, tx, ty); });
}

Result<RectI> stamp_reach(const QuantizedStamp& q, const WorldParams& world, const TextureRegistry* textures,
                          const StampLimits& limits) {
  LOAM_TRY(check_quantized(q, world, limits, textures));
  auto baked = bake_stamp(q, world, q.kind == StampKind::kShockwave ? nullptr : textures);
  LOAM_TRY(baked);
  if (q.kind == StampKind::kShockwave) return shockwave_box(baked.value(), layer_sample_rect(world, q.layer));
  return baked.value().rect;
}

Result<uint64_t> stamp_cost(const QuantizedStamp& q, const WorldParams& world,
                            const TextureRegistry* textures, const StampLimits& limits) {
  auto reach = stamp_reach(q, world, textures, limits);
  LOAM_TRY(reach);
  const uint64_t samples = uint64_t(std::max<int64_t>(reach.value().area(), 1));
  if (q.kind != StampKind::kShockwave) return samples;
  return samples * uint64_t(std::max<int32_t>(q.steps, 1)) * uint64_t(shockwave_substeps(q.speed));
}

Result<RectI> apply_stamp_with_contact(World& world, const QuantizedStamp& q, const FootprintContact& contact,
                                       const TextureRegistry* textures, const StampLimits& limits) {
  if (!stamp_kind(q.kind).needs_contact) return apply_stamp(world, q, textures, limits);
  LOAM_TRY(check_quantized(q, world.params(), limits, textures));
  auto baked = bake_stamp(q, world.params(), textures);
  LOAM_TRY(baked);
  BakedStamp& b = baked.value();
  set_contact(b, contact);
  const FastStamp fast(b, FastIsa::kBest);
  return walk_tiles(world, b,
                    [&](auto* tile, int64_t tx, int64_t ty) { return fast.apply_in_tile(tile, tx, ty); });
}

Result<RectI> apply_stamp(World& world, const QuantizedStamp& q, const TextureRegistry* textures,
                          const StampLimits& limits) {
  return apply_stamp_with(world, q, FastIsa::kBest, textures, limits);
}

}  // namespace loam
