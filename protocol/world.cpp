#include "protocol/world.h"

#include <xxhash.h>

#include <algorithm>
#include <cassert>
#include <cstring>

#include "protocol/tile_hash.h"
#include "protocol/wire/byte_stream.h"
#include "protocol/wire/fields.h"

namespace loam {

World::World(const WorldParams& params, uint16_t fill) : World(params, std::make_shared<FillBase>(fill)) {}

World::World(const WorldParams& params, std::shared_ptr<const TileBase> base)
    : params_(params),
      samples_(params.sample_rect()),
      detail_samples_(params.detail_sample_rect()),
      base_(std::move(base)) {
  assert(params.validate().ok());
  assert(base_);
  const int32_t mips = params_.mip_count();
  mips_.resize(size_t(mips));
  for (int32_t m = 0; m < mips; ++m) mips_[size_t(m)].tiles = params_.tile_range(m);
}

Result<World> World::from_samples(const WorldParams& params, std::span<const uint16_t> samples) {
  LOAM_TRY(params.validate());
  const RectI r = params.sample_rect();
  if (samples.size() != size_t(r.area())) {
    return make_error(ErrorCode::kInvalidArgument, "samples",
                      "expected " + std::to_string(r.area()) + " samples for " +
                          std::to_string(params.tiles_x) + "x" + std::to_string(params.tiles_y) +
                          " tiles, got " + std::to_string(samples.size()));
  }
  World w(params, 0);
  w.write_coarse(r, samples);
  w.commit(0);
  return w;
}

bool World::tile_in_range(int32_t mip, int32_t tx, int32_t ty) const {
  if (mip < 0 || size_t(mip) >= mips_.size()) return false;
  return mips_[size_t(mip)].tiles.contains(tx, ty);
}

World::CachedTile& World::base_tile(int32_t mip, int32_t tx, int32_t ty) const {
  if (base_->uniform()) {
    if (uniform_.data.empty()) {
      uniform_.data.resize(kTileSamples);
      base_->coarse_tile(0, 0, 0, uniform_.data);
      uniform_.hash = hash_coarse_tile(uniform_.data);
      uniform_.hashed = true;
      ++base_generated_;
    }
    return uniform_;
  }
  auto [it, added] = cache_.try_emplace(TileCoord{Layer::kCoarse, uint8_t(mip), tx, ty});
  CachedTile& t = it->second;
  if (added) {
    t.data.resize(kTileSamples);
    base_->coarse_tile(mip, tx, ty, t.data);
    cache_bytes_ += t.data.size() * sizeof(uint16_t);
    ++base_generated_;
  }
  t.last_use = ++cache_clock_;
  return t;
}

uint64_t World::base_tile_hash(int32_t mip, int32_t tx, int32_t ty) const {
  if (base_->uniform()) {
    CachedTile& t = base_tile(mip, tx, ty);
    return t.hash;
  }
  // Hashes outlive the cache (16 bytes a tile against 128 KiB), so TileHashes rounds over
  // untouched tiles do not generate them again.
  const TileCoord c{Layer::kCoarse, uint8_t(mip), tx, ty};
  if (const auto it = base_hashes_.find(c); it != base_hashes_.end()) return it->second;
  CachedTile& t = base_tile(mip, tx, ty);
  if (!t.hashed) {
    t.hash = hash_coarse_tile(t.data);
    t.hashed = true;
  }
  base_hashes_.emplace(c, t.hash);
  return t.hash;
}

const World::EditedTile* World::edited(int32_t mip, int32_t tx, int32_t ty) const {
  const auto& e = mips_[size_t(mip)].edited;
  const auto it = e.find(key(tx, ty));
  return it == e.end() ? nullptr : &it->second;
}

World::EditedTile& World::materialize(int32_t mip, int32_t tx, int32_t ty) {
  auto [it, added] = mips_[size_t(mip)].edited.try_emplace(key(tx, ty));
  EditedTile& e = it->second;
  if (added) {
    const CachedTile& b = base_tile(mip, tx, ty);
    e.data = b.data;
    e.base_hash = base_tile_hash(mip, tx, ty);
    e.state = TileState{0, e.base_hash};
    if (mip == 0 && memo_.data && memo_.tx == tx && memo_.ty == ty) memo_.data = nullptr;
  }
  return e;
}

const uint16_t* World::mip0_tile(int32_t tx, int32_t ty) const {
  if (memo_.data && memo_.tx == tx && memo_.ty == ty) return memo_.data;
  const EditedTile* e = edited(0, tx, ty);
  const uint16_t* d = e ? e->data.data() : base_tile(0, tx, ty).data.data();
  memo_.tx = tx;
  memo_.ty = ty;
  memo_.data = d;
  return d;
}

void World::trim_base_cache() {
  memo_.data = nullptr;
  if (cache_bytes_ <= cache_budget_) return;
  std::vector<std::pair<uint64_t, TileCoord>> order;
  order.reserve(cache_.size());
  for (const auto& [c, t] : cache_) order.push_back({t.last_use, c});
  std::sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [use, c] : order) {
    if (cache_bytes_ <= cache_budget_) break;
    const auto it = cache_.find(c);
    cache_bytes_ -= it->second.data.size() * sizeof(uint16_t);
    cache_.erase(it);
  }
}

std::vector<TileCoord> World::edited_coarse_tiles(int32_t mip) const {
  std::vector<TileCoord> out;
  if (mip < 0 || size_t(mip) >= mips_.size()) return out;
  for (const auto& [k, e] : mips_[size_t(mip)].edited)
    out.push_back(
        TileCoord{Layer::kCoarse, uint8_t(mip), int32_t(uint64_t(k) >> 32), int32_t(uint32_t(uint64_t(k)))});
  std::sort(out.begin(), out.end(),
            [](const TileCoord& a, const TileCoord& b) { return a.ty != b.ty ? a.ty < b.ty : a.tx < b.tx; });
  return out;
}

size_t World::edited_coarse_tile_count() const {
  size_t n = 0;
  for (const CoarseMip& m : mips_) n += m.edited.size();
  return n;
}

size_t World::edited_bytes() const {
  return edited_coarse_tile_count() * kTileSamples * sizeof(uint16_t) + detail_.size() * kTileSamples;
}

uint16_t World::coarse(int64_t gx, int64_t gy) const {
  gx = std::clamp(gx, samples_.x0, samples_.x1 - 1);
  gy = std::clamp(gy, samples_.y0, samples_.y1 - 1);
  const uint16_t* tile = mip0_tile(int32_t(gx >> kTileShift), int32_t(gy >> kTileShift));
  return tile[size_t((gy & (kTileSize - 1)) * kTileSize + (gx & (kTileSize - 1)))];
}

int8_t World::detail(int64_t dx, int64_t dy) const {
  dx = std::clamp(dx, detail_samples_.x0, detail_samples_.x1 - 1);
  dy = std::clamp(dy, detail_samples_.y0, detail_samples_.y1 - 1);
  const auto it = detail_.find(key(int32_t(dx >> kTileShift), int32_t(dy >> kTileShift)));
  if (it == detail_.end()) return 0;
  return it->second[size_t((dy & (kTileSize - 1)) * kTileSize + (dx & (kTileSize - 1)))];
}

void World::read_coarse(const RectI& r, std::span<uint16_t> out) const {
  assert(out.size() >= size_t(r.area()));
  const int64_t w = r.width();
  for (int64_t y = r.y0; y < r.y1; ++y) {
    uint16_t* row = out.data() + (y - r.y0) * w;
    const int64_t cy = std::clamp(y, samples_.y0, samples_.y1 - 1);
    int64_t x = r.x0;
    // Left clamp region, then whole runs inside tiles, then right clamp region.
    for (; x < std::min(r.x1, samples_.x0); ++x) row[x - r.x0] = coarse(x, cy);
    while (x < std::min(r.x1, samples_.x1)) {
      const int32_t tx = int32_t(x >> kTileShift);
      const int64_t run_end = std::min({r.x1, samples_.x1, (int64_t(tx) + 1) * kTileSize});
      const uint16_t* tile = mip0_tile(tx, int32_t(cy >> kTileShift));
      std::memcpy(row + (x - r.x0), tile + (cy & (kTileSize - 1)) * kTileSize + (x & (kTileSize - 1)),
                  size_t(run_end - x) * sizeof(uint16_t));
      x = run_end;
    }
    for (; x < r.x1; ++x) row[x - r.x0] = coarse(x, cy);
  }
}

void World::read_detail(const RectI& r, std::span<int8_t> out) const {
  assert(out.size() >= size_t(r.area()));
  const int64_t w = r.width();
  for (int64_t y = r.y0; y < r.y1; ++y) {
    for (int64_t x = r.x0; x < r.x1; ++x) out[size_t((y - r.y0) * w + (x - r.x0))] = detail(x, y);
  }
}

int64_t World::write_coarse(const RectI& r, std::span<const uint16_t> in) {
  assert(in.size() >= size_t(r.area()));
  const RectI clipped = r.intersect(samples_);
  int64_t changed = 0;
  const RectI tiles = tiles_overlapping(clipped);
  for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
    for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
      const RectI part = clipped.intersect(tile_rect(int32_t(tx), int32_t(ty)));
      // Compare against what the tile holds now; copy it out of the base only on a change.
      const uint16_t* now = mip0_tile(int32_t(tx), int32_t(ty));
      uint16_t* tile = nullptr;
      RectI dirty;
      for (int64_t y = part.y0; y < part.y1; ++y) {
        const uint16_t* src = in.data() + (y - r.y0) * r.width() + (part.x0 - r.x0);
        const size_t at = size_t((y - ty * kTileSize) * kTileSize + (part.x0 - tx * kTileSize));
        int64_t first = -1, last = -1;
        for (int64_t i = 0; i < part.width(); ++i) {
          if ((tile ? tile : now)[at + size_t(i)] != src[i]) {
            if (!tile) tile = materialize(0, int32_t(tx), int32_t(ty)).data.data();
            tile[at + size_t(i)] = src[i];
            if (first < 0) first = i;
            last = i;
            ++changed;
          }
        }
        if (first >= 0) dirty = dirty.unite({part.x0 + first, y, part.x0 + last + 1, y + 1});
      }
      if (!dirty.empty()) mark_dirty(Layer::kCoarse, dirty);
    }
  }
  return changed;
}

int64_t World::write_detail(const RectI& r, std::span<const int8_t> in) {
  assert(in.size() >= size_t(r.area()));
  const RectI clipped = r.intersect(detail_samples_);
  int64_t changed = 0;
  const RectI tiles = tiles_overlapping(clipped);
  for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
    for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
      const RectI part = clipped.intersect(tile_rect(int32_t(tx), int32_t(ty)));
      const auto found = detail_.find(key(int32_t(tx), int32_t(ty)));
      RectI dirty;
      std::vector<int8_t>* tile = found == detail_.end() ? nullptr : &found->second;
      for (int64_t y = part.y0; y < part.y1; ++y) {
        const int8_t* src = in.data() + (y - r.y0) * r.width() + (part.x0 - r.x0);
        for (int64_t i = 0; i < part.width(); ++i) {
          const size_t at = size_t((y - ty * kTileSize) * kTileSize + (part.x0 + i - tx * kTileSize));
          const int8_t old = tile ? (*tile)[at] : int8_t{0};
          if (old == src[i]) continue;
          if (!tile)
            tile = &detail_.try_emplace(key(int32_t(tx), int32_t(ty)), kTileSamples, int8_t{0}).first->second;
          (*tile)[at] = src[i];
          dirty = dirty.unite({part.x0 + i, y, part.x0 + i + 1, y + 1});
          ++changed;
        }
      }
      if (!dirty.empty()) mark_dirty(Layer::kDetail, dirty);
    }
  }
  return changed;
}

std::span<const uint16_t> World::coarse_tile(int32_t mip, int32_t tx, int32_t ty) const {
  if (!tile_in_range(mip, tx, ty)) return {};
  if (mip == 0) return {mip0_tile(tx, ty), size_t(kTileSamples)};
  if (const EditedTile* e = edited(mip, tx, ty)) return e->data;
  return base_tile(mip, tx, ty).data;
}

std::span<uint16_t> World::coarse_tile_mut(int32_t tx, int32_t ty) {
  if (!tile_in_range(0, tx, ty)) return {};
  return materialize(0, tx, ty).data;
}

std::span<const int8_t> World::detail_tile(int32_t tx, int32_t ty) const {
  const auto it = detail_.find(key(tx, ty));
  if (it == detail_.end()) return {};
  return it->second;
}

std::span<int8_t> World::detail_tile_mut(int32_t tx, int32_t ty) {
  const RectI dtiles = tiles_overlapping(detail_samples_);
  if (!dtiles.contains(tx, ty)) return {};
  return detail_.try_emplace(key(tx, ty), kTileSamples, int8_t{0}).first->second;
}

void World::discard_tile(Layer layer, int32_t tx, int32_t ty) {
  pending_.erase(TileCoord{layer, 0, tx, ty});
  if (layer == Layer::kDetail) {
    detail_.erase(key(tx, ty));
    detail_state_.erase(key(tx, ty));
    return;
  }
  if (memo_.data && memo_.tx == tx && memo_.ty == ty) memo_.data = nullptr;
  mips_[0].edited.erase(key(tx, ty));
}

void World::mark_dirty(Layer layer, const RectI& global_rect) {
  const RectI clipped = global_rect.intersect(layer == Layer::kCoarse ? samples_ : detail_samples_);
  const RectI tiles = tiles_overlapping(clipped);
  for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
    for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
      const RectI local =
          clipped.intersect(tile_rect(int32_t(tx), int32_t(ty))).translated(-tx * kTileSize, -ty * kTileSize);
      RectI& merged = pending_[TileCoord{layer, 0, int32_t(tx), int32_t(ty)}];
      merged = merged.unite(local);
    }
  }
}

// Mip m sample (i, j) is mip-0 sample clamp(i * 2^m, j * 2^m). A mip-0 dirty rect affects
// the mip samples whose clamped source lies inside it; at the world's edge that includes
// every sample beyond the edge, which repeats the edge sample.
void World::update_mips(const RectI& dirty0, std::unordered_map<TileCoord, RectI, TileCoordHash>& changed) {
  for (int32_t m = 1; m < int32_t(mips_.size()); ++m) {
    const int64_t step = int64_t(1) << m;
    const RectI affected = mip_samples_reaching(params_, m, dirty0);
    // No early exit: a coarser mip can have samples beyond the edge that a finer one lacks.
    if (affected.empty()) continue;
    const RectI tiles = tiles_overlapping(affected);
    for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
      for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
        const RectI part = affected.intersect(tile_rect(int32_t(tx), int32_t(ty)));
        uint16_t* tile = nullptr;
        RectI dirty;
        for (int64_t j = part.y0; j < part.y1; ++j) {
          for (int64_t i = part.x0; i < part.x1; ++i) {
            const uint16_t v = coarse(i * step, j * step);
            const size_t at = size_t((j - ty * kTileSize) * kTileSize + (i - tx * kTileSize));
            if (!tile) {
              const EditedTile* e = edited(m, int32_t(tx), int32_t(ty));
              const uint16_t now = e ? e->data[at] : base_tile(m, int32_t(tx), int32_t(ty)).data[at];
              if (now == v) continue;
              tile = materialize(m, int32_t(tx), int32_t(ty)).data.data();
            }
            if (tile[at] != v) {
              tile[at] = v;
              dirty = dirty.unite({i, j, i + 1, j + 1});
            }
          }
        }
        if (!dirty.empty()) {
          RectI& merged = changed[TileCoord{Layer::kCoarse, uint8_t(m), int32_t(tx), int32_t(ty)}];
          merged = merged.unite(dirty.translated(-tx * kTileSize, -ty * kTileSize));
        }
      }
    }
  }
}

std::vector<TileChange> World::commit(uint64_t seq) {
  std::unordered_map<TileCoord, RectI, TileCoordHash> changed = std::move(pending_);
  pending_.clear();
  std::vector<RectI> coarse_dirty;
  for (const auto& [c, r] : changed) {
    if (c.layer == Layer::kCoarse)
      coarse_dirty.push_back(r.translated(int64_t(c.tx) * kTileSize, int64_t(c.ty) * kTileSize));
  }
  if (!mip0_only_) {
    for (const RectI& r : coarse_dirty) update_mips(r, changed);
  }

  if (seq == 0 && !changed.empty()) initial_is_base_ = false;  // version 0 is not the base's
  std::vector<TileChange> out;
  out.reserve(changed.size());
  for (const auto& [c, r] : changed) {
    TileChange change{c, r, 0, seq};
    if (c.layer == Layer::kCoarse) {
      EditedTile& e = materialize(c.mip, c.tx, c.ty);
      change.base_version = e.state.version;
      e.state.version = seq;
      e.state.hash = hash_coarse_tile(e.data);
    } else {
      TileState& st = detail_state_[key(c.tx, c.ty)];
      change.base_version = st.version;
      st.version = seq;
      const auto it = detail_.find(key(c.tx, c.ty));
      if (it != detail_.end() &&
          std::all_of(it->second.begin(), it->second.end(), [](int8_t v) { return v == 0; })) {
        detail_.erase(it);  // canonical sparse form: zero tiles are not stored
        st.hash = zero_detail_tile_hash();
      } else {
        st.hash = it == detail_.end() ? zero_detail_tile_hash() : hash_detail_tile(it->second);
      }
    }
    out.push_back(change);
  }
  std::sort(out.begin(), out.end(),
            [](const TileChange& a, const TileChange& b) { return a.coord < b.coord; });
  return out;
}

TileState World::tile_state(const TileCoord& c) const {
  if (c.layer == Layer::kCoarse) {
    if (!tile_in_range(c.mip, c.tx, c.ty)) return {};
    if (const EditedTile* e = edited(c.mip, c.tx, c.ty)) return e->state;
    return TileState{0, base_tile_hash(c.mip, c.tx, c.ty)};
  }
  if (c.mip != 0) return {};
  const auto it = detail_state_.find(key(c.tx, c.ty));
  if (it == detail_state_.end()) return TileState{0, zero_detail_tile_hash()};
  return it->second;
}

bool World::restore_version(const TileCoord& c, uint64_t version) {
  if (c.layer == Layer::kCoarse) {
    if (!tile_in_range(c.mip, c.tx, c.ty)) return false;
    if (version == 0 && !edited(c.mip, c.tx, c.ty)) return true;  // untouched stays untouched
    materialize(c.mip, c.tx, c.ty).state.version = version;
    return true;
  }
  if (c.mip != 0 || !tiles_overlapping(detail_samples_).contains(c.tx, c.ty)) return false;
  TileState& st = detail_state_[key(c.tx, c.ty)];
  const auto it = detail_.find(key(c.tx, c.ty));
  st.hash = it == detail_.end() ? zero_detail_tile_hash() : hash_detail_tile(it->second);
  st.version = version;
  return true;
}

std::vector<TileCoord> World::stored_detail_tiles() const {
  std::vector<TileCoord> out;
  out.reserve(detail_.size());
  for (const auto& [k, tile] : detail_) {
    out.push_back(TileCoord{Layer::kDetail, 0, int32_t(uint64_t(k) >> 32), int32_t(uint32_t(uint64_t(k)))});
  }
  std::sort(out.begin(), out.end(),
            [](const TileCoord& a, const TileCoord& b) { return a.ty != b.ty ? a.ty < b.ty : a.tx < b.tx; });
  return out;
}

uint64_t world_hash_of(const WorldParams& p, uint64_t content_hash) {
  // Little-endian fields in WorldParams' declaration order (the log's layout), then the
  // content hash: XXH3-64, seed 0.
  std::vector<uint8_t> b;
  wire::WriteStream s(b);
  WorldParams copy = p;
  (void)wire::serialize_world_params(s, copy);
  uint64_t c = content_hash;
  (void)s.bits(c, "world.content_hash");
  return XXH3_64bits(b.data(), b.size());
}

uint64_t World::world_hash() const { return world_hash_of(params_, content_hash()); }
uint64_t World::legacy_world_hash() const { return world_hash_of(params_, legacy_content_hash()); }

namespace {

// The "layer" byte of the base's record in the content hash (layers are 0 and 1).
constexpr uint8_t kBaseRecord = 0xB0;

}  // namespace

void World::add_detail_hashes(WorldHasher& h) const {
  // Detail tiles by committed state, so a tile created but never changed counts as absent.
  std::vector<std::pair<TileCoord, uint64_t>> detail;
  for (const auto& [k, st] : detail_state_) {
    if (st.hash == zero_detail_tile_hash()) continue;
    detail.push_back(
        {TileCoord{Layer::kDetail, 0, int32_t(uint64_t(k) >> 32), int32_t(uint32_t(uint64_t(k)))}, st.hash});
  }
  std::sort(detail.begin(), detail.end(), [](const auto& a, const auto& b) {
    return a.first.ty != b.first.ty ? a.first.ty < b.first.ty : a.first.tx < b.first.tx;
  });
  for (const auto& [c, hash] : detail) h.add(uint8_t(Layer::kDetail), c.tx, c.ty, hash);
}

uint64_t World::content_hash() const {
  WorldHasher h;
  const uint64_t id = base_->identity();
  h.add(kBaseRecord, int32_t(uint32_t(id >> 32)), int32_t(uint32_t(id)), id);
  for (const TileCoord& c : edited_coarse_tiles(0)) {
    const EditedTile* e = edited(0, c.tx, c.ty);
    if (e->state.hash != e->base_hash) h.add(uint8_t(Layer::kCoarse), c.tx, c.ty, e->state.hash);
  }
  add_detail_hashes(h);
  return h.finish();
}

bool World::matches_recorded_hash(uint64_t recorded) const {
  const uint64_t content = content_hash();
  if (recorded == content || recorded == world_hash_of(params_, content)) return true;
  if (!base_->uniform()) return false;
  const uint64_t legacy = legacy_content_hash();
  return recorded == legacy || recorded == world_hash_of(params_, legacy);
}

uint64_t World::legacy_content_hash() const {
  WorldHasher h;
  const RectI t0 = mips_[0].tiles;
  for (int64_t ty = t0.y0; ty < t0.y1; ++ty) {
    for (int64_t tx = t0.x0; tx < t0.x1; ++tx)
      h.add(uint8_t(Layer::kCoarse), int32_t(tx), int32_t(ty),
            tile_state(TileCoord{Layer::kCoarse, 0, int32_t(tx), int32_t(ty)}).hash);
  }
  add_detail_hashes(h);
  return h.finish();
}

}  // namespace loam
