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
  t.last_use = ++residency_.clock;
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

const std::vector<uint16_t>& World::resident(int32_t mip, int32_t tx, int32_t ty, const EditedTile& e) const {
  auto& t = const_cast<EditedTile&>(e);  // residence is a cache: the content is the same
  t.last_use = ++residency_.clock;
  if (t.data.empty()) {
    t.data.resize(kTileSamples);
    source_->read_coarse_tile(mip, tx, ty, t.data);
    residency_.persisted_bytes += t.data.size() * sizeof(uint16_t);
    ++residency_.loaded;
  }
  return t.data;
}

World::EditedTile& World::materialize(int32_t mip, int32_t tx, int32_t ty) {
  auto [it, added] = mips_[size_t(mip)].edited.try_emplace(key(tx, ty));
  EditedTile& e = it->second;
  if (added) {
    const CachedTile& b = base_tile(mip, tx, ty);
    e.data = b.data;
    e.base_hash = base_tile_hash(mip, tx, ty);
    e.state = TileState{0, e.base_hash};
    ++dirty_coarse_;
    if (mip == 0 && memo_.data && memo_.tx == tx && memo_.ty == ty) memo_.data = nullptr;
  } else {
    resident(mip, tx, ty, e);
  }
  return e;
}

void World::set_persisted(EditedTile& e, bool persisted) {
  if (e.persisted == persisted) return;
  e.persisted = persisted;
  const size_t bytes = e.data.size() * sizeof(uint16_t);
  if (persisted) {
    residency_.persisted_bytes += bytes;
    --dirty_coarse_;
  } else {
    residency_.persisted_bytes -= bytes;
    ++dirty_coarse_;
  }
}

World::EditedTile& World::writable(int32_t mip, int32_t tx, int32_t ty) {
  EditedTile& e = materialize(mip, tx, ty);
  set_persisted(e, false);
  return e;
}

const uint16_t* World::mip0_tile(int32_t tx, int32_t ty) const {
  if (memo_.data && memo_.tx == tx && memo_.ty == ty) return memo_.data;
  const EditedTile* e = edited(0, tx, ty);
  const uint16_t* d = e ? resident(0, tx, ty, *e).data() : base_tile(0, tx, ty).data.data();
  memo_.tx = tx;
  memo_.ty = ty;
  memo_.data = d;
  return d;
}

void World::trim_base_cache() {
  memo_.data = nullptr;
  // Dirty tiles cannot go, but they count: clean tiles make room for them.
  const size_t dirty = unpersisted_bytes();
  const size_t budget = cache_budget_ > dirty ? cache_budget_ - dirty : 0;
  if (cache_bytes_ + residency_.persisted_bytes <= budget) return;
  // Trimming sorts every clean tile: go 1/16 under a large budget, so it runs once in many
  // ticks rather than on every one at the budget.
  const size_t target = budget >= 16 * kTileSamples * sizeof(uint16_t) ? budget - budget / 16 : budget;
  // Clean tiles of both kinds, least recently used first: base tiles (cache_), and edited
  // tiles the store holds at their current state (read back on the next use).
  struct Candidate {
    uint64_t last_use;
    int kind;  // 0 base, 1 edited coarse, 2 detail
    TileCoord c;
  };
  std::vector<Candidate> order;
  order.reserve(cache_.size());
  for (const auto& [c, t] : cache_) order.push_back({t.last_use, 0, c});
  for (size_t m = 0; m < mips_.size(); ++m) {
    for (const auto& [k, e] : mips_[m].edited) {
      if (e.persisted && !e.data.empty())
        order.push_back({e.last_use, 1, {Layer::kCoarse, uint8_t(m), tile_key_x(k), tile_key_y(k)}});
    }
  }
  for (const auto& [k, t] : detail_.tiles()) {
    if (t.persisted && !t.data.empty())
      order.push_back({t.last_use, 2, {Layer::kDetail, 0, tile_key_x(k), tile_key_y(k)}});
  }
  std::sort(order.begin(), order.end(),
            [](const Candidate& a, const Candidate& b) { return a.last_use < b.last_use; });
  for (const Candidate& o : order) {
    if (cache_bytes_ + residency_.persisted_bytes <= target) break;
    if (o.kind == 0) {
      const auto it = cache_.find(o.c);
      cache_bytes_ -= it->second.data.size() * sizeof(uint16_t);
      cache_.erase(it);
    } else if (o.kind == 1) {
      EditedTile& e = mips_[o.c.mip].edited.at(key(o.c.tx, o.c.ty));
      residency_.persisted_bytes -= e.data.size() * sizeof(uint16_t);
      std::vector<uint16_t>().swap(e.data);
    } else {
      detail_.evict(key(o.c.tx, o.c.ty), residency_);
    }
  }
}

void World::replace_base(std::shared_ptr<const TileBase> base) {
  assert(base && base->identity() == base_->identity());
  base_ = std::move(base);
}

bool World::needs_base_read(int32_t mip, int32_t tx, int32_t ty) const {
  if (!tile_in_range(mip, tx, ty) || base_->uniform()) return false;
  if (edited(mip, tx, ty)) return false;
  return !cache_.count(TileCoord{Layer::kCoarse, uint8_t(mip), tx, ty});
}

void World::set_edit_source(std::shared_ptr<const EditedTileSource> source) { source_ = std::move(source); }

std::vector<World::EditedTileInfo> World::edited_tiles() const {
  std::vector<EditedTileInfo> out;
  for (size_t m = 0; m < mips_.size(); ++m) {
    for (const auto& [k, e] : mips_[m].edited) {
      out.push_back(
          {{Layer::kCoarse, uint8_t(m), tile_key_x(k), tile_key_y(k)}, e.state, e.base_hash, e.persisted});
    }
  }
  for (const auto& [k, t] : detail_.tiles()) {
    if (t.state.version == 0 && t.data.empty() && !t.evicted) continue;  // never changed
    out.push_back({{Layer::kDetail, 0, tile_key_x(k), tile_key_y(k)}, t.state, 0, t.persisted});
  }
  std::sort(out.begin(), out.end(),
            [](const EditedTileInfo& a, const EditedTileInfo& b) { return a.coord < b.coord; });
  return out;
}

std::vector<TileCoord> World::unpersisted_tiles() const {
  std::vector<TileCoord> out;
  for (size_t m = 0; m < mips_.size(); ++m) {
    for (const auto& [k, e] : mips_[m].edited) {
      if (!e.persisted) out.push_back({Layer::kCoarse, uint8_t(m), tile_key_x(k), tile_key_y(k)});
    }
  }
  for (const auto& [k, t] : detail_.tiles()) {
    if (!t.persisted) out.push_back({Layer::kDetail, 0, tile_key_x(k), tile_key_y(k)});
  }
  std::sort(out.begin(), out.end());
  return out;
}

size_t World::unpersisted_bytes() const {
  return dirty_coarse_ * kTileSamples * sizeof(uint16_t) + detail_.unpersisted_bytes();
}

void World::mark_persisted(const TileCoord& c, uint64_t version) {
  const bool pending = pending_.count({c.layer, 0, c.tx, c.ty}) != 0;
  visit_layer(c.layer, [&](auto row) {
    using R = decltype(row);
    if constexpr (R::kHasBase) {
      if (size_t(c.mip) >= mips_.size()) return;
      auto& edited = mips_[c.mip].edited;
      const auto it = edited.find(key(c.tx, c.ty));
      if (it != edited.end() && it->second.state.version == version && (c.mip != 0 || !pending))
        set_persisted(it->second, true);
    } else {
      sparse<R>().mark_persisted(key(c.tx, c.ty), version, pending, residency_);
    }
  });
}

bool World::adopt_persisted(const TileCoord& c, const TileState& state, uint64_t base_hash) {
  if (!source_ || !layer_tile_range(params_, c.layer, c.mip).contains(c.tx, c.ty)) return false;
  visit_layer(c.layer, [&](auto row) {
    using R = decltype(row);
    if constexpr (R::kHasBase) {
      const auto [it, added] = mips_[c.mip].edited.try_emplace(key(c.tx, c.ty));
      EditedTile& e = it->second;
      if (e.persisted) residency_.persisted_bytes -= e.data.size() * sizeof(uint16_t);
      if (!added && !e.persisted) --dirty_coarse_;
      std::vector<uint16_t>().swap(e.data);
      e.state = state;
      e.base_hash = base_hash;
      e.persisted = true;
      if (c.mip == 0) memo_.data = nullptr;
    } else {
      sparse<R>().adopt(key(c.tx, c.ty), state, residency_);
    }
  });
  return true;
}

std::vector<TileCoord> World::edited_coarse_tiles(int32_t mip) const {
  std::vector<TileCoord> out;
  if (mip < 0 || size_t(mip) >= mips_.size()) return out;
  for (const auto& [k, e] : mips_[size_t(mip)].edited)
    out.push_back(TileCoord{Layer::kCoarse, uint8_t(mip), tile_key_x(k), tile_key_y(k)});
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
  size_t n = 0;
  for (const CoarseMip& m : mips_) {
    for (const auto& [k, e] : m.edited) n += e.data.size() * sizeof(uint16_t);
  }
  return n + detail_.bytes();
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
  const std::vector<int8_t>* t = detail_samples(key(int32_t(dx >> kTileShift), int32_t(dy >> kTileShift)));
  if (!t) return 0;
  return (*t)[size_t((dy & (kTileSize - 1)) * kTileSize + (dx & (kTileSize - 1)))];
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
            if (!tile) tile = writable(0, int32_t(tx), int32_t(ty)).data.data();
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
      RectI dirty;
      std::vector<int8_t>* tile = detail_samples(key(int32_t(tx), int32_t(ty)));
      bool claimed = false;
      for (int64_t y = part.y0; y < part.y1; ++y) {
        const int8_t* src = in.data() + (y - r.y0) * r.width() + (part.x0 - r.x0);
        for (int64_t i = 0; i < part.width(); ++i) {
          const size_t at = size_t((y - ty * kTileSize) * kTileSize + (part.x0 + i - tx * kTileSize));
          const int8_t old = tile ? (*tile)[at] : int8_t{0};
          if (old == src[i]) continue;
          if (!claimed) {
            tile = &writable_detail(int32_t(tx), int32_t(ty));
            claimed = true;
          }
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
  if (const EditedTile* e = edited(mip, tx, ty)) return resident(mip, tx, ty, *e);
  return base_tile(mip, tx, ty).data;
}

std::span<uint16_t> World::coarse_tile_mut(int32_t tx, int32_t ty) {
  if (!tile_in_range(0, tx, ty)) return {};
  return writable(0, tx, ty).data;
}

std::span<const int8_t> World::detail_tile(int32_t tx, int32_t ty) const {
  const std::vector<int8_t>* t = detail_samples(key(tx, ty));
  if (!t) return {};
  return *t;
}

std::span<int8_t> World::detail_tile_mut(int32_t tx, int32_t ty) {
  const RectI dtiles = tiles_overlapping(detail_samples_);
  if (!dtiles.contains(tx, ty)) return {};
  return writable_detail(tx, ty);
}

void World::discard_tile(Layer layer, int32_t tx, int32_t ty) {
  pending_.erase(TileCoord{layer, 0, tx, ty});
  visit_layer(layer, [&](auto row) {
    using R = decltype(row);
    if constexpr (R::kHasBase) {
      if (memo_.data && memo_.tx == tx && memo_.ty == ty) memo_.data = nullptr;
      const auto it = mips_[0].edited.find(key(tx, ty));
      if (it == mips_[0].edited.end()) return;
      set_persisted(it->second, false);
      --dirty_coarse_;
      mips_[0].edited.erase(it);
    } else {
      sparse<R>().discard(key(tx, ty), residency_);
    }
  });
}

void World::mark_dirty(Layer layer, const RectI& global_rect) {
  const RectI clipped = global_rect.intersect(layer_sample_rect(params_, layer));
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
              const uint16_t now = e ? resident(m, int32_t(tx), int32_t(ty), *e)[at]
                                     : base_tile(m, int32_t(tx), int32_t(ty)).data[at];
              if (now == v) continue;
              tile = writable(m, int32_t(tx), int32_t(ty)).data.data();
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
  // Mips follow the mip-0 rects of the layer that has them.
  std::vector<RectI> mip0_dirty;
  for (const auto& [c, r] : changed) {
    if (layer_info(c.layer).has_mips)
      mip0_dirty.push_back(r.translated(int64_t(c.tx) * kTileSize, int64_t(c.ty) * kTileSize));
  }
  if (!mip0_only_) {
    for (const RectI& r : mip0_dirty) update_mips(r, changed);
  }

  if (seq == 0 && !changed.empty()) initial_is_base_ = false;  // version 0 is not the base's
  std::vector<TileChange> out;
  out.reserve(changed.size());
  for (const auto& [coord, r] : changed) {
    const TileCoord& c = coord;  // a plain reference: lambdas capture no structured binding in C++20
    TileChange change{c, r, 0, seq};
    change.base_version = visit_layer(c.layer, [&](auto row) -> uint64_t {
      using R = decltype(row);
      if constexpr (R::kHasBase) {
        EditedTile& e = writable(c.mip, c.tx, c.ty);
        const uint64_t before = e.state.version;
        e.state.version = seq;
        e.state.hash = hash_coarse_tile(e.data);
        return before;
      } else {
        return sparse<R>().commit(key(c.tx, c.ty), seq, residency_, detail_load());
      }
    });
    out.push_back(change);
  }
  std::sort(out.begin(), out.end(),
            [](const TileChange& a, const TileChange& b) { return a.coord < b.coord; });
  return out;
}

TileState World::tile_state(const TileCoord& c) const {
  if (!layer_has_mip(c.layer, c.mip)) return {};
  return visit_layer(c.layer, [&](auto row) {
    using R = decltype(row);
    if constexpr (R::kHasBase) {
      if (!tile_in_range(c.mip, c.tx, c.ty)) return TileState{};
      if (const EditedTile* e = edited(c.mip, c.tx, c.ty)) return e->state;
      return TileState{0, base_tile_hash(c.mip, c.tx, c.ty)};
    } else {
      return sparse<R>().state(key(c.tx, c.ty));  // all zero wherever never written
    }
  });
}

std::optional<TileState> World::known_tile_state(const TileCoord& c) const {
  // Only an untouched tile of a layer with a base may need reading to be hashed.
  if (layer_info(c.layer).has_base && tile_in_range(c.mip, c.tx, c.ty) && !base_->uniform() &&
      !edited(c.mip, c.tx, c.ty) && !base_hashes_.count(c) && !cache_.count(c))
    return std::nullopt;
  return tile_state(c);
}

uint64_t World::tile_version(const TileCoord& c) const {
  if (!layer_tile_range(params_, c.layer, c.mip).contains(c.tx, c.ty)) return 0;
  return visit_layer(c.layer, [&](auto row) -> uint64_t {
    using R = decltype(row);
    if constexpr (R::kHasBase) {
      const EditedTile* e = edited(c.mip, c.tx, c.ty);
      return e ? e->state.version : 0;
    } else {
      return sparse<R>().version(key(c.tx, c.ty));
    }
  });
}

bool World::restore_version(const TileCoord& c, uint64_t version) {
  if (!layer_tile_range(params_, c.layer, c.mip).contains(c.tx, c.ty)) return false;
  visit_layer(c.layer, [&](auto row) {
    using R = decltype(row);
    if constexpr (R::kHasBase) {
      if (version == 0 && !edited(c.mip, c.tx, c.ty)) return;  // untouched stays untouched
      writable(c.mip, c.tx, c.ty).state.version = version;
    } else {
      sparse<R>().restore_version(key(c.tx, c.ty), version, residency_, detail_load());
    }
  });
  return true;
}

std::vector<TileCoord> World::stored_detail_tiles() const {
  std::vector<TileCoord> out;
  out.reserve(detail_.stored_count());
  for (const auto& [k, tile] : detail_.tiles()) {
    if (!tile.data.empty() || tile.evicted)
      out.push_back(TileCoord{Layer::kDetail, 0, tile_key_x(k), tile_key_y(k)});
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
  for (const auto& [k, t] : detail_.tiles()) {
    const TileState& st = t.state;
    if (st.hash == zero_detail_tile_hash()) continue;
    detail.push_back({TileCoord{Layer::kDetail, 0, tile_key_x(k), tile_key_y(k)}, st.hash});
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
