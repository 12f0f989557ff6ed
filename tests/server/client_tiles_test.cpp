// The replication planner (server/replication/client_tiles.h) as tables: what a client holds
// x the stamp's kind x the tiles and mips it changes -> whether the client gets the event,
// which tiles it then follows by itself, and which regions become due (a patch over a held
// version, or the whole tile). No sockets, no clock: each row runs in microseconds.
#include "server/replication/client_tiles.h"

#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

namespace loam::server {
namespace {

constexpr TileCoord a0{Layer::kCoarse, 0, 0, 0};
constexpr TileCoord b0{Layer::kCoarse, 0, 1, 0};
constexpr TileCoord a1{Layer::kCoarse, 1, 0, 0};
constexpr TileCoord a2{Layer::kCoarse, 2, 0, 0};
constexpr TileCoord d0{Layer::kDetail, 0, 0, 0};

struct Held {
  TileCoord tile;
  std::optional<uint64_t> version;  // nullopt: subscribed, first region not sent yet
};

struct Expect {
  TileCoord tile;
  uint64_t held;                 // the version recorded for the client afterwards
  bool due;                      // a region is due
  std::optional<uint64_t> base;  // due: a patch over this version (nullopt: whole tile)
};

struct Row {
  std::string what;
  StampKind kind;
  Layer layer;
  std::vector<Held> holds;
  std::vector<TileChange> changes;  // the stamp is sequence 10
  bool gets_event;
  std::vector<Expect> after;
};

TileChange change(const TileCoord& c, uint64_t base, RectI rect = {10, 10, 20, 20}) {
  return {c, rect, base, 10};
}

TEST(ClientTilesPlanner, TableOfHeldVersionsKindsAndMips) {
  const std::vector<Row> rows = {
      {"in sync at every mip: the event alone",
       StampKind::kCrater,
       Layer::kCoarse,
       {{a0, 4}, {a1, 4}, {a2, 3}},
       {change(a0, 4), change(a1, 4), change(a2, 3)},
       true,
       {{a0, 10, false, {}}, {a1, 10, false, {}}, {a2, 10, false, {}}}},
      {"only coarse mips held (a far viewer): the event alone",
       StampKind::kGaussian,
       Layer::kCoarse,
       {{a1, 4}, {a2, 3}},
       {change(a0, 4), change(a1, 4), change(a2, 3)},
       true,
       {{a1, 10, false, {}}, {a2, 10, false, {}}}},
      {"footprint across two mip-0 tiles, one held: the event alone",
       StampKind::kFootprint,
       Layer::kCoarse,
       {{a0, 4}},
       {change(a0, 4), change(b0, 2)},
       true,
       {{a0, 10, false, {}}}},
      {"shockwave: mip 0 follows, its mips become patches",
       StampKind::kShockwave,
       Layer::kCoarse,
       {{a0, 4}, {a1, 4}},
       {change(a0, 4), change(a1, 4, {3, 3, 9, 9})},
       true,
       {{a0, 10, false, {}}, {a1, 4, true, 4}}},
      {"a held tile behind: every held changed tile is due as a patch",
       StampKind::kCrater,
       Layer::kCoarse,
       {{a0, 2}, {a1, 4}},
       {change(a0, 4), change(a1, 4)},
       true,
       {{a0, 2, true, 2}, {a1, 4, true, 4}}},
      {"first region not sent yet: stays whole, the others follow",
       StampKind::kGaussian,
       Layer::kCoarse,
       {{a0, std::nullopt}, {a1, 4}},
       {change(a0, 4), change(a1, 4)},
       true,
       {{a0, 0, true, {}}, {a1, 10, false, {}}}},
      {"stamp touches nothing subscribed: no event",
       StampKind::kGaussian,
       Layer::kCoarse,
       {{b0, 4}},
       {change(a0, 4), change(a1, 4)},
       false,
       {{b0, 4, false, {}}}},
      {"detail stamp on a held detail tile",
       StampKind::kGaussian,
       Layer::kDetail,
       {{d0, 7}, {a0, 4}},
       {change(d0, 7)},
       true,
       {{d0, 10, false, {}}, {a0, 4, false, {}}}},
  };
  for (const Row& r : rows) {
    SCOPED_TRACE(r.what);
    ClientTiles tiles;
    for (const Held& h : r.holds) tiles.subscribe(h.tile, h.version, h.version.value_or(99));
    // A tile subscribed without a version starts due (its whole tile has not gone yet).
    wire::DeformEvent e;
    e.global_seq = 10;
    e.stamp.kind = r.kind;
    e.stamp.layer = r.layer;
    for (const TileChange& c : r.changes) e.base_versions.push_back({c.coord, c.base_version});
    EXPECT_EQ(tiles.plan_event(e, r.changes), r.gets_event);
    for (const Expect& x : r.after) {
      const TileInterest* t = tiles.find(x.tile);
      ASSERT_NE(t, nullptr) << to_string(x.tile);
      EXPECT_EQ(t->held.value_or(0), x.held) << to_string(x.tile);
      EXPECT_EQ(t->due, x.due) << to_string(x.tile);
      if (x.due) {
        EXPECT_EQ(tiles.need(x.tile).base, x.base) << to_string(x.tile);
      }
    }
  }
}

TEST(ClientTilesPlanner, ChangesToAQueuedTileCoalesceIntoOnePatchOfTheirUnion) {
  ClientTiles tiles;
  tiles.subscribe(a0, 2, 2);
  wire::DeformEvent e;
  e.stamp.kind = StampKind::kGaussian;
  for (uint64_t seq : {5u, 6u, 7u}) {
    e.global_seq = seq;
    const int64_t at = int64_t(seq) * 10;
    const TileChange c{a0, RectI{at, at, at + 4, at + 4}, seq == 5 ? 4u : seq - 1, seq};
    e.base_versions = {{a0, c.base_version}};
    EXPECT_TRUE(tiles.plan_event(e, std::span(&c, 1)));
  }
  EXPECT_EQ(tiles.due_count(), 1u);
  const RegionNeed n = tiles.need(a0);
  EXPECT_EQ(n.base, std::optional<uint64_t>(2));
  EXPECT_EQ(n.rect, (RectI{50, 50, 74, 74}));
  tiles.mark_sent(a0, 7);
  EXPECT_EQ(tiles.due_count(), 0u);
  EXPECT_EQ(tiles.find(a0)->held, std::optional<uint64_t>(7));
}

TEST(ClientTilesPlanner, ALargeChangeSendsTheWholeTileNotAPatch) {
  ClientTiles tiles;
  tiles.subscribe(a0, 2, 2);
  wire::DeformEvent e;
  e.global_seq = 5;
  e.stamp.kind = StampKind::kShockwave;
  const TileChange c{a1, RectI{0, 0, 200, 200}, 2, 5};
  tiles.subscribe(a1, 2, 2);
  e.base_versions = {{a1, 2}};
  EXPECT_TRUE(tiles.plan_event(e, std::span(&c, 1)));
  EXPECT_FALSE(tiles.need(a1).base.has_value());  // 40000 samples > a quarter of the tile
  EXPECT_EQ(tiles.need(a1).rect, (RectI{0, 0, kTileSize, kTileSize}));
}

TEST(ClientTilesPlanner, DueRegionsLeaveTheCoarsestLevelFirstThenNearestTheFocus) {
  ClientTiles tiles;
  const std::vector<TileCoord> all = {{Layer::kCoarse, 0, 0, 0}, {Layer::kCoarse, 0, 5, 0},
                                      {Layer::kCoarse, 0, 2, 0}, {Layer::kCoarse, 1, 2, 0},
                                      {Layer::kCoarse, 1, 0, 0}, {Layer::kCoarse, 2, 0, 0}};
  for (const TileCoord& c : all) tiles.subscribe(c, std::nullopt, 0);
  tiles.set_focus(std::make_pair(5.5 * kTileSize, 0.5 * kTileSize));  // over mip-0 tile (5, 0)
  // The top level; then the tiles holding the focus (finer first); then by distance.
  const std::vector<TileCoord> expected = {{Layer::kCoarse, 2, 0, 0}, {Layer::kCoarse, 0, 5, 0},
                                           {Layer::kCoarse, 1, 2, 0}, {Layer::kCoarse, 0, 2, 0},
                                           {Layer::kCoarse, 1, 0, 0}, {Layer::kCoarse, 0, 0, 0}};
  EXPECT_EQ(tiles.due_in_order(), expected);
  tiles.set_focus(std::nullopt);  // no focus: coarsest mip first
  const std::vector<TileCoord> by_mip = {{Layer::kCoarse, 2, 0, 0}, {Layer::kCoarse, 1, 0, 0},
                                         {Layer::kCoarse, 1, 2, 0}, {Layer::kCoarse, 0, 0, 0},
                                         {Layer::kCoarse, 0, 2, 0}, {Layer::kCoarse, 0, 5, 0}};
  EXPECT_EQ(tiles.due_in_order(), by_mip);
}

TEST(ClientTilesPlanner, SubscribingAtTheCurrentVersionNeedsNothing) {
  ClientTiles tiles;
  tiles.subscribe(a0, 0, 0);   // the initial terrain, held
  tiles.subscribe(a1, 3, 8);   // held, but stale
  tiles.subscribe(a2, {}, 0);  // not held
  EXPECT_FALSE(tiles.find(a0)->due);
  EXPECT_TRUE(tiles.find(a1)->due);
  EXPECT_FALSE(tiles.need(a1).base.has_value());  // the samples changed since 3 are unknown: whole
  EXPECT_TRUE(tiles.find(a2)->due);
  EXPECT_EQ(tiles.due_count(), 2u);
  tiles.unsubscribe(a1);
  EXPECT_EQ(tiles.size(), 2u);
}

}  // namespace
}  // namespace loam::server
