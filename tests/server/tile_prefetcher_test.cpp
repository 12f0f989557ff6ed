// PrefetchingBase (server/tile_prefetcher.h): tiles queued ahead are made on its worker and
// answer the reads that follow with exactly the inner base's samples; a tile never queued is
// made on the reader's thread, as without a prefetcher; prepared tiles stay within their bound.
#include "server/tile_prefetcher.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

namespace loam::server {
namespace {

using namespace std::chrono_literals;

// A base whose samples depend on the tile and which records the threads that made tiles.
class RecordingBase final : public TileBase {
 public:
  void coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const override {
    for (size_t i = 0; i < out.size(); ++i) out[i] = uint16_t(mip * 7919 + tx * 131 + ty * 17 + int32_t(i));
    std::lock_guard lock(mu_);
    threads_.insert(std::this_thread::get_id());
    ++calls_;
  }
  uint64_t identity() const override { return 42; }
  std::string describe() const override { return "recording"; }
  std::set<std::thread::id> threads() const {
    std::lock_guard lock(mu_);
    return threads_;
  }
  int calls() const {
    std::lock_guard lock(mu_);
    return calls_;
  }

 private:
  mutable std::mutex mu_;
  mutable std::set<std::thread::id> threads_;
  mutable int calls_ = 0;
};

bool wait_for(const std::function<bool()>& done) {
  for (int i = 0; i < 500; ++i) {
    if (done()) return true;
    std::this_thread::sleep_for(10ms);
  }
  return done();
}

TEST(PrefetchingBase, QueuedTilesAreMadeOnItsWorkerAndReadBackAsTheInnerBaseMakesThem) {
  auto inner = std::make_shared<RecordingBase>();
  PrefetchingBase base(inner, 16);
  EXPECT_EQ(base.identity(), inner->identity()) << "World and snapshots see the same base";
  std::vector<TileCoord> tiles;
  for (int32_t i = 0; i < 8; ++i) tiles.push_back({Layer::kCoarse, uint8_t(i % 3), i, -i});
  base.prefetch(tiles);
  base.prefetch(tiles);  // queued or ready already: not made twice
  ASSERT_TRUE(wait_for([&] { return base.stats().prepared == tiles.size(); }));
  EXPECT_EQ(inner->calls(), int(tiles.size()));
  EXPECT_EQ(inner->threads().count(std::this_thread::get_id()), 0u) << "made off the asking thread";

  std::vector<uint16_t> got(kTileSamples), want(kTileSamples);
  for (const TileCoord& c : tiles) {
    base.coarse_tile(c.mip, c.tx, c.ty, got);
    inner->coarse_tile(c.mip, c.tx, c.ty, want);
    EXPECT_EQ(got, want) << to_string(c);
  }
  EXPECT_EQ(base.stats().ready_hits, tiles.size());
  EXPECT_EQ(base.ready(), 0u) << "a tile read is handed over, not kept";
}

TEST(PrefetchingBase, ATileNeverQueuedIsMadeOnTheReadersThread) {
  auto inner = std::make_shared<RecordingBase>();
  PrefetchingBase base(inner, 4);
  std::vector<uint16_t> got(kTileSamples), want(kTileSamples);
  base.coarse_tile(2, 5, 6, got);
  inner->coarse_tile(2, 5, 6, want);
  EXPECT_EQ(got, want);
  EXPECT_EQ(base.stats().made_inline, 1u);
  EXPECT_EQ(inner->threads().count(std::this_thread::get_id()), 1u);
}

TEST(PrefetchingBase, PreparedTilesStayWithinTheirBound) {
  auto inner = std::make_shared<RecordingBase>();
  PrefetchingBase base(inner, 4);
  for (int32_t round = 0; round < 5; ++round) {
    std::vector<TileCoord> tiles;
    for (int32_t i = 0; i < 10; ++i) tiles.push_back({Layer::kCoarse, 0, round * 10 + i, 0});
    base.prefetch(tiles);
    ASSERT_TRUE(wait_for([&] {
      const auto s = base.stats();
      return s.prepared == s.queued;
    }));
    EXPECT_LE(base.ready(), 4u);
  }
  EXPECT_GT(base.stats().dropped, 0u) << "tiles nobody read make room for new ones";
  // Whatever was dropped or never queued still reads right.
  std::vector<uint16_t> got(kTileSamples), want(kTileSamples);
  for (int32_t i = 0; i < 50; i += 7) {
    base.coarse_tile(0, i, 0, got);
    inner->coarse_tile(0, i, 0, want);
    EXPECT_EQ(got, want);
  }
}

}  // namespace
}  // namespace loam::server
