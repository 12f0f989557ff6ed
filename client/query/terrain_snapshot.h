// TerrainSnapshot: an immutable copy of the terrain a player sees (the display: confirmed
// state plus the player's own unsettled stamps), mip 0 of both layers, for the height and
// collision queries of game code (terrain_query.h).
//
// Tiles are shared between snapshots: a new snapshot copies only the tiles that changed since
// the last one, so publishing one per network update costs the changed tiles, not the world.
// A snapshot never changes once made, so any number of threads may query it while the network
// thread builds the next (the exchange itself is SnapshotSlot's). Each coarse tile carries
// the minimum and maximum of every 16 x 16-sample block, which rays and sweeps use to skip
// what they cannot touch.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include "protocol/geometry.h"

namespace loam::query {

inline constexpr int32_t kBlockSamples = 16;  // block side, samples
inline constexpr int32_t kBlocksPerTile = kTileSize / kBlockSamples;

struct CoarseTile {
  std::vector<uint16_t> samples;  // kTileSamples, row-major
  std::array<uint16_t, kBlocksPerTile * kBlocksPerTile> block_min{}, block_max{};
};
struct DetailTile {
  std::vector<int8_t> samples;  // kTileSamples, row-major (detail grid)
  int32_t largest_offset = 0;   // max |sample|
};

std::shared_ptr<const CoarseTile> make_coarse_tile(std::span<const uint16_t> samples);
std::shared_ptr<const DetailTile> make_detail_tile(std::span<const int8_t> samples);

class TerrainSnapshot {
 public:
  using CoarseMap = std::unordered_map<uint64_t, std::shared_ptr<const CoarseTile>>;
  using DetailMap = std::unordered_map<uint64_t, std::shared_ptr<const DetailTile>>;

  // What the snapshot reflects: every event the display had applied up to `event_seq` (the
  // newest global sequence received) and the own stamps it showed; `generation` counts
  // snapshots published.
  struct Stamp {
    uint64_t generation = 0;
    uint64_t event_seq = 0;
    size_t own_stamps_shown = 0;
  };

  TerrainSnapshot(const WorldParams& params, CoarseMap coarse, DetailMap detail, Stamp stamp);

  const WorldParams& params() const { return params_; }
  const Stamp& stamp() const { return stamp_; }
  static uint64_t key(int64_t tx, int64_t ty) { return (uint64_t(uint32_t(tx)) << 32) | uint32_t(ty); }

  // A held mip-0 tile, or null.
  const CoarseTile* coarse_tile(int64_t tx, int64_t ty) const {
    const auto it = coarse_.find(key(tx, ty));
    return it == coarse_.end() ? nullptr : it->second.get();
  }
  const DetailTile* detail_tile(int64_t tx, int64_t ty) const {
    const auto it = detail_.find(key(tx, ty));
    return it == detail_.end() ? nullptr : it->second.get();
  }
  size_t coarse_tiles() const { return coarse_.size(); }
  size_t detail_tiles() const { return detail_.size(); }
  // Bytes of samples this snapshot refers to (shared with other snapshots).
  size_t bytes() const;
  // The largest detail offset held, meters (0 with no detail): bounds what detail adds.
  double detail_extent_m() const { return detail_extent_m_; }
  // The world's sample rect (coarse grid); a sample outside it is never held.
  const RectI& world_samples() const { return world_; }

  const CoarseMap& coarse_map() const { return coarse_; }
  const DetailMap& detail_map() const { return detail_; }

 private:
  WorldParams params_;
  RectI world_;
  CoarseMap coarse_;
  DetailMap detail_;
  Stamp stamp_;
  double detail_extent_m_ = 0.0;
};

// Where the network thread puts each new snapshot and game threads take the latest. take()
// and publish() hold a lock only for the exchange of one pointer (no allocation, no copy of
// samples); a query then runs on its snapshot without any lock.
class SnapshotSlot {
 public:
  std::shared_ptr<const TerrainSnapshot> take() const { return slot_.load(std::memory_order_acquire); }
  void publish(std::shared_ptr<const TerrainSnapshot> s) {
    slot_.store(std::move(s), std::memory_order_release);
  }

 private:
  std::atomic<std::shared_ptr<const TerrainSnapshot>> slot_;
};

}  // namespace loam::query
