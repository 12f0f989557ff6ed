// The tiles of a sparse layer: a layer without a base (protocol/layer.h, kHasBase false), whose
// untouched samples are zero, such as the detail offsets. Mip 0 only; a tile whose samples are
// all zero is not stored. Once a store holds a tile's state (persisted) its samples may be
// evicted and are read back on their next use. World holds one store per sparse layer and the
// residency counters its LRU trim runs on, shared with the layers that have a base.
// Generic over the sample type: a new sparse layer (material, moisture) needs no new storage.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <unordered_map>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/tile_hash.h"

namespace loam {

struct TileState {
  uint64_t version = 0;  // sequence number of the last stamp that changed the tile
  uint64_t hash = 0;     // hash of its samples (tile_hash.h)
};

// What a world's tiles of every layer share for residency: the LRU clock, the bytes of
// persisted (evictable) samples in memory, and how many tiles were read back from the store.
struct TileResidency {
  uint64_t clock = 0;
  size_t persisted_bytes = 0;
  uint64_t loaded = 0;
};

// A tile's key in a layer's maps, and back.
constexpr int64_t tile_key(int32_t tx, int32_t ty) {
  return int64_t((uint64_t(uint32_t(tx)) << 32) | uint32_t(ty));
}
constexpr int32_t tile_key_x(int64_t k) { return int32_t(uint64_t(k) >> 32); }
constexpr int32_t tile_key_y(int64_t k) { return int32_t(uint32_t(uint64_t(k))); }

// `Load(tx, ty, std::span<T>)` reads a persisted tile's samples back from the store; the
// calls that may read back take it, so the store stays free of I/O.
template <class T>
class SparseTiles {
 public:
  struct Tile {
    std::vector<T> data;  // empty: all zero, or evicted (see `evicted`)
    TileState state;      // committed state
    bool persisted = false;
    bool evicted = false;  // non-zero samples held only by the store
    uint64_t last_use = 0;
  };

  // The hash of an absent (all-zero) tile.
  static uint64_t zero_hash() {
    static const uint64_t h = [] {
      const std::vector<T> zeros(kTileSamples, T{0});
      return hash_tile(std::span<const T>(zeros));
    }();
    return h;
  }

  // Every tile ever written, changed or adopted, by key.
  const std::unordered_map<int64_t, Tile>& tiles() const { return tiles_; }
  // Tiles with non-zero samples (resident or evicted).
  size_t stored_count() const { return stored_; }
  // Tiles changed since a store last held them: what the next snapshot writes.
  size_t dirty_count() const { return dirty_; }
  size_t unpersisted_bytes() const { return dirty_ * size_t(kTileSamples) * sizeof(T); }
  size_t bytes() const {
    size_t n = 0;
    for (const auto& [k, t] : tiles_) n += bytes_of(t);
    return n;
  }

  // The tile's samples (nullptr: all zero), read back from the store if evicted.
  template <class Load>
  std::vector<T>* samples(int64_t k, TileResidency& r, const Load& load) {
    const auto it = tiles_.find(k);
    if (it == tiles_.end()) return nullptr;
    Tile& t = it->second;
    if (t.evicted) {
      t.data.resize(kTileSamples);
      load(tile_key_x(k), tile_key_y(k), std::span<T>(t.data));
      t.evicted = false;
      r.persisted_bytes += bytes_of(t);
      ++r.loaded;
    }
    if (t.data.empty()) return nullptr;
    t.last_use = ++r.clock;
    return &t.data;
  }

  // The tile's samples about to be written (created as zeros): no longer clean.
  template <class Load>
  std::vector<T>& writable(int64_t k, TileResidency& r, const Load& load) {
    const auto [it, added] = tiles_.try_emplace(k);
    Tile& t = it->second;
    if (added || t.persisted) ++dirty_;
    if (t.evicted) samples(k, r, load);
    if (t.data.empty()) {
      t.data.assign(kTileSamples, T{0});
      ++stored_;
    } else if (t.persisted) {
      r.persisted_bytes -= bytes_of(t);
    }
    t.persisted = false;
    t.last_use = ++r.clock;
    return t.data;
  }

  // Brings the tile's committed state up to `seq` after writes; returns its version before.
  template <class Load>
  uint64_t commit(int64_t k, uint64_t seq, TileResidency& r, const Load& load) {
    std::vector<T>& data = writable(k, r, load);
    Tile& t = tiles_.at(k);
    const uint64_t before = t.state.version;
    t.state.version = seq;
    if (std::all_of(data.begin(), data.end(), [](T v) { return v == T{0}; })) {
      std::vector<T>().swap(data);  // canonical sparse form: zero tiles are not stored
      --stored_;
      t.state.hash = zero_hash();
    } else {
      t.state.hash = hash_tile(std::span<const T>(data));
    }
    return before;
  }

  TileState state(int64_t k) const {
    const auto it = tiles_.find(k);
    return it == tiles_.end() ? TileState{0, zero_hash()} : it->second.state;
  }
  uint64_t version(int64_t k) const {
    const auto it = tiles_.find(k);
    return it == tiles_.end() ? 0 : it->second.state.version;
  }

  // A store holds the tile at `version`: clean (evictable) unless it changed since or has
  // uncommitted writes (`pending`).
  void mark_persisted(int64_t k, uint64_t version, bool pending, TileResidency& r) {
    const auto it = tiles_.find(k);
    if (it == tiles_.end() || it->second.state.version != version || it->second.persisted || pending) return;
    it->second.persisted = true;
    r.persisted_bytes += bytes_of(it->second);
    --dirty_;
  }

  // A tile the store holds and memory does not: its state, samples left to read back.
  void adopt(int64_t k, const TileState& state, TileResidency& r) {
    const auto [it, added] = tiles_.try_emplace(k);
    Tile& t = it->second;
    const bool had = !t.data.empty() || t.evicted;
    if (t.persisted) r.persisted_bytes -= bytes_of(t);
    if (!added && !t.persisted) --dirty_;
    std::vector<T>().swap(t.data);
    t.state = state;
    t.persisted = true;
    t.evicted = state.hash != zero_hash();
    stored_ += size_t(t.evicted) - size_t(had);
  }

  // Sets the version of the tile's current samples (loading a snapshot); no longer clean.
  template <class Load>
  void restore_version(int64_t k, uint64_t version, TileResidency& r, const Load& load) {
    const auto [it, added] = tiles_.try_emplace(k);
    Tile& t = it->second;
    if (t.evicted) samples(k, r, load);
    t.state.hash = t.data.empty() ? zero_hash() : hash_tile(std::span<const T>(t.data));
    t.state.version = version;
    if (t.persisted) {
      r.persisted_bytes -= bytes_of(t);
      ++dirty_;
    } else if (added) {
      ++dirty_;
    }
    t.persisted = false;
  }

  // Forgets the tile: it reads as zeros at version 0.
  void discard(int64_t k, TileResidency& r) {
    const auto it = tiles_.find(k);
    if (it == tiles_.end()) return;
    if (!it->second.data.empty() || it->second.evicted) --stored_;
    if (it->second.persisted) {
      r.persisted_bytes -= bytes_of(it->second);
    } else {
      --dirty_;
    }
    tiles_.erase(it);
  }

  // Drops a persisted tile's samples from memory (the trim's choice); read back on next use.
  void evict(int64_t k, TileResidency& r) {
    Tile& t = tiles_.at(k);
    r.persisted_bytes -= bytes_of(t);
    std::vector<T>().swap(t.data);
    t.evicted = true;
  }

 private:
  static size_t bytes_of(const Tile& t) { return t.data.size() * sizeof(T); }

  std::unordered_map<int64_t, Tile> tiles_;
  size_t stored_ = 0;
  size_t dirty_ = 0;
};

}  // namespace loam
