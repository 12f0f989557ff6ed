#include "client/terrain/display_terrain.h"

#include <algorithm>
#include <climits>
#include <optional>

#include "protocol/stamps/stamp_apply.h"
#include "protocol/world_layers.h"

namespace loam::terrain {

namespace {

bool intersects(const RectI& a, const RectI& b) { return !a.intersect(b).empty(); }

bool intersects_any(const std::vector<RectI>& rects, const RectI& r) {
  return std::any_of(rects.begin(), rects.end(), [&](const RectI& s) { return intersects(s, r); });
}

// Samples of a layer over `rect` as int32 (either layer), for comparisons.
std::vector<int32_t> read_layer(const World& w, Layer layer, const RectI& rect) {
  return read_rect_i32(w, layer, rect);
}

}  // namespace

DisplayTerrain::DisplayTerrain(const client::ConfirmedStore& store, const TextureRegistry* textures)
    : store_(&store), textures_(textures), display_(store.mirror().params(), 0) {
  display_.set_mip0_only(true);  // levels read coarser mips from the store
}

DisplayTerrain::~DisplayTerrain() = default;

Result<std::unique_ptr<DisplayTerrain>> DisplayTerrain::create(const client::ConfirmedStore& store,
                                                               const DisplayStamperFactory& gpu,
                                                               const TextureRegistry* textures) {
  std::unique_ptr<DisplayTerrain> d(new DisplayTerrain(store, textures));
  // Start from whatever the store already holds (a reconnect keeps it): its held mip-0
  // tiles, nothing else (the display, like the store, follows the subscription).
  for (const TileCoord& c : store.held()) {
    if (c.mip != 0) continue;
    visit_layer(c.layer, [&](auto row) {
      using R = decltype(row);
      // An unstored tile (detail) is all zero, as the display's is already.
      if (const auto t = store.mirror().tile_samples<R>(c); !t.empty())
        (void)LayerOps<R>::write(d->display_, tile_rect(c.tx, c.ty), t);
    });
  }
  d->display_.commit(0);
  if (gpu) {
    auto stamper = gpu(d->display_, textures);
    if (!stamper) return stamper.error();
    d->stamper_ = std::move(*stamper);
  }
  return d;
}

bool DisplayTerrain::holds_mip0(Layer layer, const RectI& reach) const {
  const RectI tiles = tiles_overlapping(reach);
  for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
    for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
      if (!store_->holds({layer, 0, int32_t(tx), int32_t(ty)})) return false;
    }
  }
  return true;
}

void DisplayTerrain::stamp(const QuantizedStamp& q) {
  // The GPU copy first: a page it fills fresh reads the mirror, which must not hold q yet.
  const bool on_gpu = stamper_ && stamper_->submit(q).ok();
  auto r = apply_stamp(display_, q, textures_);
  const RectI changed = r ? *r : RectI{};
  if (!changed.empty()) cpu_done_.push_back({q.layer, changed, on_gpu});
  if (stamper_) {
    // The store validated q (or rejects it the same way: it changes nothing, as on the
    // server). Where the cache could not take it (every page held, or more tiles than its
    // budget), the mirror's result goes up instead.
    if (!on_gpu && !changed.empty()) stamper_->upload(display_, q.layer, changed);
    stamper_->end_batch();
  }
}

void DisplayTerrain::finish(std::vector<DisplayDirty>& dirty) {
  dirty.insert(dirty.end(), cpu_done_.begin(), cpu_done_.end());
  cpu_done_.clear();
}

int64_t DisplayTerrain::copy_from_store(Layer layer, const RectI& rect, bool upload) {
  const RectI r = rect.intersect(layer_sample_rect(display_.params(), layer));
  if (r.empty()) return 0;
  const int64_t changed = copy_rect(store_->mirror(), display_, layer, r);
  counters_.texels_copied += uint64_t(r.area());
  // Where nothing changed the GPU copy already holds these samples (it holds the CPU copy's).
  if (stamper_ && upload && changed > 0) stamper_->upload(display_, layer, r);
  return changed;
}

std::vector<int32_t> DisplayTerrain::expected_after(const Pending& p,
                                                    const std::vector<client::StoreChange>& changes) const {
  // Other stamps' events of this sync that reach into ours, on our layer.
  std::vector<const client::StoreChange*> others;
  RectI reach = p.reach;
  for (const client::StoreChange& c : changes) {
    if (c.kind != client::StoreChange::Kind::kEvent || c.layer != p.stamp.layer || c.rect.empty()) continue;
    const bool ours = std::any_of(pending_.begin(), pending_.end(),
                                  [&](const Pending& q) { return q.acked && q.global_seq == c.seq; });
    if (ours) continue;
    auto r = stamp_reach(c.stamp, display_.params(), textures_);
    if (!r || !intersects(*r, p.reach)) continue;
    others.push_back(&c);
    reach = reach.unite(*r);
  }
  if (others.empty()) return read_layer(display_, p.stamp.layer, p.reach);
  // Apply them to a small copy of the displayed tiles holding every reach involved.
  const WorldParams& wp = display_.params();
  const int64_t k = visit_layer(p.stamp.layer, [&](auto row) { return decltype(row)::resolution(wp); });
  const RectI coarse{floor_div(reach.x0, k), floor_div(reach.y0, k), ceil_div(reach.x1, k),
                     ceil_div(reach.y1, k)};
  const RectI tiles = tiles_overlapping(coarse).intersect(wp.tile_range(0));
  WorldParams cp = wp;
  cp.origin_tile_x = int32_t(tiles.x0);
  cp.origin_tile_y = int32_t(tiles.y0);
  cp.tiles_x = int32_t(tiles.width());
  cp.tiles_y = int32_t(tiles.height());
  World crop(cp, 0);
  (void)copy_rect(display_, crop, p.stamp.layer, layer_sample_rect(cp, p.stamp.layer));
  for (const client::StoreChange* c : others) (void)apply_stamp(crop, c->stamp, textures_);
  return read_layer(crop, p.stamp.layer, p.reach);
}

bool DisplayTerrain::predict(uint32_t client_seq, const QuantizedStamp& q) {
  auto reach = stamp_reach(q, display_.params(), textures_);
  if (!reach || reach->empty() || !holds_mip0(q.layer, *reach)) {
    ++counters_.not_predicted;
    return false;
  }
  Pending p;
  p.client_seq = client_seq;
  p.stamp = q;
  p.reach = *reach;
  pending_.push_back(p);
  stamp(q);
  ++counters_.predicted;
  return true;
}

std::vector<DisplayDirty> DisplayTerrain::sync(client::TerrainClient& client) {
  std::vector<DisplayDirty> dirty;
  last_changes_ = client.store().take_changes();
  const std::vector<client::StoreChange>& changes = last_changes_;
  settle(client, std::chrono::steady_clock::now());
  SyncRects rects;
  const std::vector<Expected> expected = plan_settled(changes, rects);
  follow_changes(changes, rects, dirty);
  spread_under_overlay(rects);
  copy_and_reapply(rects, dirty);
  count_and_retire(expected);
  forget_unheld();
  return dirty;
}

// 1. Which own stamps are settled: rejected, lost, or their event is in (and not waiting).
void DisplayTerrain::settle(client::TerrainClient& client, std::chrono::steady_clock::time_point now) {
  for (Pending& p : pending_) {
    p.retire = p.reapply = false;
    if (!p.acked) {
      if (const auto a = client.ack(p.client_seq)) {
        p.acked = true;
        p.accepted = a->accepted;
        // Lost with the connection: it retires, and the confirmed state after the reconnect
        // shows whether the server applied it. Queued stamps were not sent: they stay predicted.
        p.abandoned = a->lost;
        p.global_seq = a->global_seq;
        p.ack_time = now;
      }
    }
    if (!p.acked) continue;
    // Acknowledged before a reconnect whose Welcome is at or past it: its event will not come,
    // the tiles the server sends hold it.
    p.retire = !p.accepted ||
               (client.last_event_seq() >= p.global_seq && !client.store().is_buffered(p.global_seq)) ||
               p.global_seq <= client.welcome().global_sequence || now - p.ack_time > retire_timeout_;
  }
}

// 2. What each settled prediction should turn into: what it showed, plus the events of other
// stamps that arrive with it (the server may have ordered them either side of ours). Its reach
// is copied from the store; the others' reaches are the overlay.
std::vector<DisplayTerrain::Expected> DisplayTerrain::plan_settled(
    const std::vector<client::StoreChange>& changes, SyncRects& rects) {
  std::vector<Expected> expected;
  for (const Pending& p : pending_) {
    if (!p.retire) {
      rects.overlay[p.stamp.layer].push_back(p.reach);
      continue;
    }
    rects.add_stale(p.stamp.layer, p.reach, true);
    // A rejected stamp simply disappears; an accepted one is compared with what happened.
    if (p.accepted) expected.push_back({p.stamp.layer, p.reach, expected_after(p, changes)});
  }
  return expected;
}

// 3. Follow the store's changes. An event whose reach the display shows as confirmed is
// followed by copying the samples it changed from the store (after the stale rects, below) and,
// with a GPU copy, by stamping it there: the same shaders give the same samples (the
// conformance tests and audit_gpu() hold them to it), and nothing comes back. Everything else
// becomes a stale rect, copied from the store and uploaded.
void DisplayTerrain::follow_changes(const std::vector<client::StoreChange>& changes, SyncRects& rects,
                                    std::vector<DisplayDirty>& dirty) {
  for (const client::StoreChange& c : changes) {
    const std::vector<RectI>& stale = rects.stale[c.layer];
    if (c.kind == client::StoreChange::Kind::kRegion) {
      if (c.tile.mip == 0) {
        rects.add_stale(c.layer, c.rect);
      } else {
        // Levels reading that mip change where mip 0 is not held (where it is, they read mip
        // 0, which an event's change to this mip tile also changed): the samples' mip-0 extent.
        const int64_t s = int64_t(1) << c.tile.mip;
        const RectI extent{c.rect.x0 * s, c.rect.y0 * s, c.rect.x1 * s, c.rect.y1 * s};
        if (!holds_mip0(c.layer, extent.intersect(layer_sample_rect(display_.params(), c.layer))))
          dirty.push_back({c.layer, extent});
      }
      continue;
    }
    if (c.rect.empty()) continue;
    auto reach = stamp_reach(c.stamp, display_.params(), textures_);
    const RectI r = reach ? *reach : c.rect;
    const bool confirmed_under = !intersects_any(stale, r) && !intersects_any(rects.overlay[c.layer], r);
    // The GPU copy follows by stamping where it holds the whole reach (a stamp reads all of it:
    // a footprint's contact, a shockwave's field); where it cannot (a tile under the reach is
    // not held, or the cache's pages are all held by this sync's stamps), the rect is uploaded
    // with the stale ones.
    const bool by_stamp = confirmed_under && (!stamper_ || holds_mip0(c.layer, r));
    if (by_stamp && (!stamper_ || stamper_->submit(c.stamp).ok())) {
      rects.followed[c.layer].push_back(c.rect);
      dirty.push_back({c.layer, c.rect, stamper_ != nullptr});
      ++(stamper_ ? counters_.events_stamped : counters_.events_copied);
    } else {
      // Held tiles the levels already show as the display holds them: they need the event's
      // samples only where the copy changes the display (it may hold them already: our own
      // prediction, settling).
      rects.add_stale(c.layer, c.rect, true);
      ++counters_.events_copied;
    }
  }
}

// 4. Overlay stamps over a stale rect are rebuilt whole, which makes their reach stale too.
void DisplayTerrain::spread_under_overlay(SyncRects& rects) {
  for (bool grew = true; grew;) {
    grew = false;
    for (Pending& p : pending_) {
      if (p.retire || p.reapply) continue;
      if (intersects_any(rects.stale[p.stamp.layer], p.reach)) {
        rects.add_stale(p.stamp.layer, p.reach);
        p.reapply = true;
        grew = true;
      }
    }
  }
}

// 5. Copy the confirmed samples in (the GPU copy has the events it stamped; it takes the stale
// rects), then re-apply the overlay stamps on top, in order.
void DisplayTerrain::copy_and_reapply(const SyncRects& rects, std::vector<DisplayDirty>& dirty) {
  rects.followed.for_each([&](Layer layer, const std::vector<RectI>& followed) {
    for (const RectI& r : followed) copy_from_store(layer, r, false);
  });
  rects.stale.for_each([&](Layer layer, const std::vector<RectI>& stale) {
    for (size_t i = 0; i < stale.size(); ++i) {
      const int64_t changed = copy_from_store(layer, stale[i], true);
      if (changed > 0 || !rects.quiet[layer][i]) dirty.push_back({layer, stale[i]});
    }
  });
  // The mirror now holds what every page stamped this sync holds.
  if (stamper_) stamper_->end_batch();
  for (const Pending& p : pending_) {
    if (p.reapply) stamp(p.stamp);
  }
  finish(dirty);
  display_.commit(0);
}

// 6. Corrections: texels where the confirmed result differs from what was expected; the
// settled predictions leave the overlay.
void DisplayTerrain::count_and_retire(const std::vector<Expected>& expected) {
  for (const Expected& e : expected) {
    const auto now_samples = read_layer(display_, e.layer, e.rect);
    for (size_t k = 0; k < now_samples.size(); ++k) counters_.corrections += now_samples[k] != e.samples[k];
  }
  std::erase_if(pending_, [&](const Pending& p) {
    if (!p.retire) return false;
    ++counters_.retired;
    if (p.abandoned) {
      ++counters_.abandoned;
    } else if (!p.accepted) {
      ++counters_.rejected;
    }
    return true;
  });
}

void DisplayTerrain::forget_unheld() {
  auto under_overlay = [&](Layer layer, int32_t tx, int32_t ty) {
    const RectI t = tile_rect(tx, ty);
    return std::any_of(pending_.begin(), pending_.end(),
                       [&](const Pending& p) { return p.stamp.layer == layer && intersects(p.reach, t); });
  };
  std::vector<TileCoord> tiles = display_.edited_coarse_tiles(0);
  const std::vector<TileCoord> detail = display_.stored_detail_tiles();
  tiles.insert(tiles.end(), detail.begin(), detail.end());
  for (const TileCoord& c : tiles) {
    if (store_->holds({c.layer, 0, c.tx, c.ty}) || under_overlay(c.layer, c.tx, c.ty)) continue;
    display_.discard_tile(c.layer, c.tx, c.ty);
    if (stamper_) stamper_->forget(display_, c.layer, c.tx, c.ty);
    ++counters_.tiles_forgotten;
  }
}

uint64_t DisplayTerrain::audit_gpu(size_t max_tiles) {
  if (!stamper_) return 0;
  std::vector<TileCoord> tiles = display_.edited_coarse_tiles(0);
  const std::vector<TileCoord> detail = display_.stored_detail_tiles();
  tiles.insert(tiles.end(), detail.begin(), detail.end());
  // Resident tiles only: the others are filled from the mirror when next needed.
  std::erase_if(tiles, [&](const TileCoord& c) { return !stamper_->resident(c.layer, c.tx, c.ty); });
  if (tiles.empty()) return 0;
  uint64_t diff = 0;
  for (size_t k = 0; k < std::min(max_tiles, tiles.size()); ++k) {
    const TileCoord& c = tiles[(audit_cursor_ + k) % tiles.size()];
    const RectI r = tile_rect(c.tx, c.ty).intersect(layer_sample_rect(display_.params(), c.layer));
    const std::vector<int32_t> gpu = stamper_->read(c.layer, r);
    const std::vector<int32_t> mine = read_layer(display_, c.layer, r);
    uint64_t d = 0;
    for (size_t i = 0; i < std::min(gpu.size(), mine.size()); ++i) d += gpu[i] != mine[i];
    if (d != 0) stamper_->upload(display_, c.layer, r);  // repaired
    diff += d;
  }
  audit_cursor_ = (audit_cursor_ + max_tiles) % tiles.size();
  counters_.gpu_tiles_audited += std::min(max_tiles, tiles.size());
  counters_.divergent_texels += diff;
  return diff;
}

DisplayMemory DisplayTerrain::memory() const {
  DisplayMemory m;
  m.cpu_bytes = display_.edited_bytes();
  if (stamper_) m.gpu = stamper_->memory();
  return m;
}

gpu::GpuStamperTraffic DisplayTerrain::gpu_traffic() const {
  return stamper_ ? stamper_->traffic() : gpu::GpuStamperTraffic{};
}

const gpu::GpuStamper* DisplayTerrain::gpu_cache() const { return stamper_ ? &stamper_->cache() : nullptr; }

DisplayTerrain::TileSource DisplayTerrain::source_for(int32_t mip, int32_t tx, int32_t ty) const {
  if (store_->holds({Layer::kCoarse, 0, tx, ty})) return {0, display_.coarse_tile(0, tx, ty)};
  const int32_t mips = display_.params().mip_count();
  // The mip-m tile holding every sample of mip-0 tile (tx, ty) (m >= 1: it spans 2^m tiles).
  auto from_mip = [&](int32_t m) -> std::optional<TileSource> {
    const TileCoord c{Layer::kCoarse, uint8_t(m), int32_t(floor_div(tx, int64_t(1) << m)),
                      int32_t(floor_div(ty, int64_t(1) << m))};
    const std::span<const uint16_t> t = store_->coarse_samples(c);
    if (t.empty()) return std::nullopt;
    return TileSource{m, t};
  };
  // Exact: every mip up to `mip` holds the samples a mip-`mip` level reads. Then coarser ones,
  // the nearest sample below (while finer tiles load).
  for (int32_t m = std::min(mip, mips - 1); m >= 1; --m) {
    if (const auto t = from_mip(m)) return *t;
  }
  for (int32_t m = mip + 1; m < mips; ++m) {
    if (const auto t = from_mip(m)) return *t;
  }
  return {};
}

void DisplayTerrain::set_initial_base(std::shared_ptr<const TileBase> base) {
  if (base != initial_base_) base_tiles_.clear();
  initial_base_ = std::move(base);
}

bool DisplayTerrain::may_have_changed(int32_t tx, int32_t ty) const {
  const TileCoord c{Layer::kCoarse, 0, tx, ty};
  const auto v = store_->version(c);
  if (v && *v > 0) return true;
  const RectI tile = tile_rect(tx, ty);
  // A prediction on this tile's layer reaching into it.
  for (const Pending& p : pending_) {
    if (p.stamp.layer == c.layer && !p.reach.intersect(tile).empty()) return true;
  }
  return false;
}

const uint16_t* DisplayTerrain::base_tile(int32_t tx, int32_t ty) const {
  if (!initial_base_) {
    // Not generated here: what the store kept of the tile's version 0 (or nothing known).
    const auto kept = store_->initial_coarse(tx, ty);
    return kept.empty() ? nullptr : kept.data();
  }
  auto it = base_tiles_.find({tx, ty});
  if (it == base_tiles_.end()) {
    if (base_tiles_.size() >= 64) base_tiles_.clear();
    std::vector<uint16_t> samples(kTileSamples);
    initial_base_->coarse_tile(0, tx, ty, samples);
    it = base_tiles_.emplace(std::pair{tx, ty}, std::move(samples)).first;
  }
  return it->second.data();
}

bool DisplayTerrain::read_change(int32_t mip, const RectI& rect, std::span<float> out) const {
  if (!initial_base_ && !store_->keeps_initial()) return false;
  std::vector<uint16_t> now(out.size());
  read(mip, rect, now);
  const RectI w = display_.params().sample_rect();
  const LevelAxis ax(mip, w.x0, w.x1), ay(mip, w.y0, w.y1);
  const double mpu = display_.params().meters_per_unit;
  size_t i = 0;
  int64_t cached_tx = INT64_MIN, cached_ty = INT64_MIN;
  const uint16_t* base = nullptr;  // null: the tile reads as unchanged
  for (int64_t y = rect.y0; y < rect.y1; ++y) {
    const int64_t gy = ay.position(y);
    for (int64_t x = rect.x0; x < rect.x1; ++x, ++i) {
      const int64_t gx = ax.position(x);
      const int64_t tx = floor_div(gx, kTileSize), ty = floor_div(gy, kTileSize);
      if (tx != cached_tx || ty != cached_ty) {
        cached_tx = tx, cached_ty = ty;
        base = may_have_changed(int32_t(tx), int32_t(ty)) ? base_tile(int32_t(tx), int32_t(ty)) : nullptr;
      }
      out[i] =
          base
              ? float(
                    (int32_t(now[i]) -
                     int32_t(base[size_t(floor_mod(gy, kTileSize) * kTileSize + floor_mod(gx, kTileSize))])) *
                    mpu)
              : 0.0f;
    }
  }
  return true;
}

void DisplayTerrain::read(int32_t mip, const RectI& rect, std::span<uint16_t> out) const {
  const RectI w = display_.params().sample_rect();
  const LevelAxis ax(mip, w.x0, w.x1), ay(mip, w.y0, w.y1);
  // Where samples come from is decided once per mip-0 tile, not per sample.
  int64_t cached_tx = INT64_MIN, cached_ty = INT64_MIN;
  TileSource src;
  size_t i = 0;
  for (int64_t y = rect.y0; y < rect.y1; ++y) {
    const int64_t gy = ay.position(y);
    for (int64_t x = rect.x0; x < rect.x1; ++x) {
      const int64_t gx = ax.position(x);
      const int64_t tx = floor_div(gx, kTileSize), ty = floor_div(gy, kTileSize);
      if (tx != cached_tx || ty != cached_ty) {
        src = source_for(mip, int32_t(tx), int32_t(ty));
        cached_tx = tx, cached_ty = ty;
      }
      if (src.samples.empty()) {
        out[i++] = 0;
        continue;
      }
      const int64_t j = gx >> src.mip, k = gy >> src.mip;  // floor: the nearest sample at or below
      out[i++] = src.samples[size_t(floor_mod(k, kTileSize) * kTileSize + floor_mod(j, kTileSize))];
    }
  }
}

void DisplayTerrain::read_detail(const RectI& rect, std::span<int8_t> out) const {
  size_t i = 0;
  for (int64_t y = rect.y0; y < rect.y1; ++y) {
    for (int64_t x = rect.x0; x < rect.x1; ++x) {
      const TileCoord c{Layer::kDetail, 0, int32_t(floor_div(x, kTileSize)),
                        int32_t(floor_div(y, kTileSize))};
      out[i++] = store_->holds(c) ? display_.detail(x, y) : int8_t(0);
    }
  }
}

}  // namespace loam::terrain
