// The client's confirmed store as a display follows it (client/net/confirmed_store.h): its
// change log lists regions and applied events in order with the samples they changed, and a
// region that arrives for a tile no longer wanted (sent before the Unsubscribe reached the
// server) is dropped rather than held stale.
#include "client/net/confirmed_store.h"

#include <gtest/gtest.h>

#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_at_mip.h"
#include "protocol/stamps/stamp_kernel.h"
#include "protocol/stamps/stamp_validate.h"

namespace loam::client {
namespace {

WorldParams two_by_two() {
  WorldParams p;
  p.meters_per_sample = 1.0;
  p.tiles_x = 2;
  p.tiles_y = 2;
  return p;
}

QuantizedStamp bump(const WorldParams& w, double x, double y) {
  StampParams s;
  s.kind = StampKind::kGaussian;
  s.center_x = x;
  s.center_y = y;
  s.radius = 20;
  s.intensity = 3;
  auto q = validate_stamp(s, w);
  EXPECT_TRUE(q.ok());
  return *q;
}

TEST(ConfirmedStore, ChangeLogListsRegionsAndAppliedEventsInOrderWithTheirRects) {
  const WorldParams w = two_by_two();
  ConfirmedStore store(w);
  store.record_changes(true);
  const TileCoord t00{Layer::kCoarse, 0, 0, 0};
  store.want(t00);
  const std::vector<uint16_t> flat(kTileSamples, 1000);
  ASSERT_TRUE(store.replace<CoarseLayer>(t00, 5, flat).ok());

  wire::DeformEvent e;
  e.global_seq = 6;
  e.origin_client_id = 3;
  e.stamp = bump(w, 100, 100);  // inside tile (0, 0) only
  e.base_versions = {{t00, 5}};
  EXPECT_EQ(store.on_event(e), EventOutcome::kApplied);

  World expected(w, 0);
  expected.write_coarse(tile_rect(0, 0), flat);
  const auto rect = apply_stamp(expected, e.stamp);
  ASSERT_TRUE(rect.ok());
  const std::vector<StoreChange> changes = store.take_changes();
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_EQ(changes[0].kind, StoreChange::Kind::kRegion);
  EXPECT_EQ(changes[0].tile, t00);
  EXPECT_EQ(changes[0].seq, 5u);
  EXPECT_EQ(changes[0].rect, tile_rect(0, 0));
  EXPECT_EQ(changes[1].kind, StoreChange::Kind::kEvent);
  EXPECT_EQ(changes[1].seq, 6u);
  EXPECT_EQ(changes[1].origin_client_id, 3u);
  EXPECT_EQ(changes[1].stamp, e.stamp);
  EXPECT_EQ(changes[1].rect, *rect);
  EXPECT_TRUE(store.take_changes().empty());
}

TEST(ConfirmedStore, RegionForATileNoLongerWantedIsDroppedNotHeld) {
  const WorldParams w = two_by_two();
  ConfirmedStore store(w);
  const TileCoord t10{Layer::kCoarse, 0, 1, 0};
  store.want(t10);
  store.forget(t10);
  const std::vector<uint16_t> flat(kTileSamples, 7);
  ASSERT_TRUE(store.replace<CoarseLayer>(t10, 9, flat).ok());
  EXPECT_FALSE(store.holds(t10));
  EXPECT_EQ(store.counters().regions_unwanted, 1u);
  EXPECT_EQ(store.counters().regions, 0u);
}

// The server's side of one stamp, as its DeformEvent: base versions of every changed tile and
// a footprint's contact.
wire::DeformEvent server_apply(World& server, const QuantizedStamp& q, uint64_t seq) {
  wire::DeformEvent e;
  e.global_seq = seq;
  e.stamp = q;
  if (q.kind == StampKind::kFootprint)
    e.contact = footprint_contact_of(bake_stamp(q, server.params()).value(), server);
  EXPECT_TRUE(apply_stamp(server, q).ok());
  for (const TileChange& c : server.commit(seq)) e.base_versions.push_back({c.coord, c.base_version});
  return e;
}

TEST(ConfirmedStore, StoreHoldingOnlyCoarseMipsFollowsEventsAndMatchesTheServersHashes) {
  // A far viewer: it holds mips 1 and 2 of a 4 x 4-tile world and no mip-0 tile. Every stamp
  // reaches it as an event it applies at those mips; no region is needed.
  WorldParams p;
  p.meters_per_sample = 1.0;
  p.tiles_x = 4;
  p.tiles_y = 4;
  World server(p, 0);
  std::vector<uint16_t> terrain(size_t(p.sample_rect().area()));
  for (size_t i = 0; i < terrain.size(); ++i) terrain[i] = uint16_t(20000 + (i * 7919) % 3001);
  server.write_coarse(p.sample_rect(), terrain);
  server.commit(0);

  ConfirmedStore store(p);
  store.record_changes(true);
  std::vector<TileCoord> held;
  for (int32_t m = 1; m <= 2; ++m) {
    const RectI tiles = p.tile_range(m);
    for (int32_t ty = int32_t(tiles.y0); ty < tiles.y1; ++ty) {
      for (int32_t tx = int32_t(tiles.x0); tx < tiles.x1; ++tx) {
        const TileCoord c{Layer::kCoarse, uint8_t(m), tx, ty};
        store.want(c);
        ASSERT_TRUE(store.replace<CoarseLayer>(c, 0, server.coarse_tile(m, tx, ty)).ok());
        held.push_back(c);
      }
    }
  }
  (void)store.take_changes();
  const StampKind kinds[] = {StampKind::kGaussian, StampKind::kCrater, StampKind::kFootprint,
                             StampKind::kFlatten};
  uint64_t seq = 0;
  for (int i = 0; i < 24; ++i) {
    StampParams s;
    s.kind = kinds[i % 4];
    s.center_x = 100.0 + 37.3 * i;  // walks across tile edges and corners
    s.center_y = 300.0 + 29.1 * i - (i % 3) * 150.0;
    s.radius = 12.0 + 5.0 * (i % 5);
    s.intensity = s.kind == StampKind::kFlatten ? 0.7 : 3.0;
    if (s.kind == StampKind::kFlatten) s.target = 300.0;
    if (s.kind == StampKind::kCrater) s.shape = 0.4;
    auto q = validate_stamp(s, p);
    ASSERT_TRUE(q.ok()) << q.error().describe();
    const wire::DeformEvent e = server_apply(server, *q, ++seq);
    EXPECT_EQ(store.on_event(e), EventOutcome::kApplied) << i;
  }
  size_t mip_changes = 0;
  for (const StoreChange& c : store.take_changes())
    mip_changes += c.kind == StoreChange::Kind::kRegion && c.tile.mip > 0;
  EXPECT_GT(mip_changes, 10u);
  for (const TileCoord& c : held) {
    EXPECT_EQ(store.version(c), server.tile_state(c).version) << to_string(c);
    EXPECT_EQ(store.hash(c), server.tile_state(c).hash) << to_string(c);
  }
  EXPECT_EQ(store.counters().events_buffered, 0u);
}

}  // namespace
}  // namespace loam::client

namespace loam::client {
namespace {

// Memory follows the subscription: a forgotten tile leaves the mirror, and an event whose
// stamp also covers tiles the store does not hold leaves nothing of them behind.
TEST(ConfirmedStore, MirrorHoldsOnlyHeldTilesAfterForgetAndAfterEventsOverUnheldTiles) {
  const WorldParams w = two_by_two();
  ConfirmedStore store(w);
  const TileCoord t00{Layer::kCoarse, 0, 0, 0}, t10{Layer::kCoarse, 0, 1, 0};
  const std::vector<uint16_t> flat(kTileSamples, 1000);
  for (const TileCoord& c : {t00, t10}) {
    store.want(c);
    ASSERT_TRUE(store.replace<CoarseLayer>(c, 5, flat).ok());
  }
  EXPECT_EQ(store.held_bytes(), size_t(2) * kTileSamples * 2);
  store.forget(t10);
  EXPECT_EQ(store.held_bytes(), size_t(kTileSamples) * 2);
  EXPECT_EQ(store.mirror().edited_coarse_tile_count(), 1u);

  // A bump on the corner of all four tiles; only (0, 0) is held.
  wire::DeformEvent e;
  e.global_seq = 6;
  e.stamp = bump(w, 256, 256);
  e.base_versions = {{t00, 5}, {t10, 5}, {{Layer::kCoarse, 0, 0, 1}, 0}, {{Layer::kCoarse, 0, 1, 1}, 0}};
  EXPECT_EQ(store.on_event(e), EventOutcome::kApplied);
  EXPECT_EQ(store.mirror().edited_coarse_tile_count(), 1u);
  EXPECT_EQ(store.held_bytes(), size_t(kTileSamples) * 2);
  // The held tile did change, exactly as a dense copy does.
  World expected(w, 0);
  expected.write_coarse(tile_rect(0, 0), flat);
  ASSERT_TRUE(apply_stamp(expected, e.stamp).ok());
  std::vector<uint16_t> want(kTileSamples), got(kTileSamples);
  expected.read_coarse(tile_rect(0, 0), want);
  store.mirror().read_coarse(tile_rect(0, 0), got);
  EXPECT_EQ(got, want);
  EXPECT_EQ(*store.version(t00), 6u);
}

// The dug layer over an imported DEM: the store keeps each held tile's version 0 when it first
// changes (event, whole region, patch), answers a tile still at version 0 with its own samples,
// knows nothing of a tile first held past version 0, and lets the copy go with the tile.
TEST(ConfirmedStore, KeepsTheVersionZeroOfTilesThatChangeWhileHeld) {
  const WorldParams w = two_by_two();
  ConfirmedStore store(w);
  store.keep_initial(true);
  const TileCoord t00{Layer::kCoarse, 0, 0, 0}, t10{Layer::kCoarse, 0, 1, 0}, t01{Layer::kCoarse, 0, 0, 1},
      t11{Layer::kCoarse, 0, 1, 1};
  std::vector<uint16_t> initial(kTileSamples);
  for (size_t i = 0; i < initial.size(); ++i) initial[i] = uint16_t(1000 + i % 977);
  for (const TileCoord& c : {t00, t10, t01}) {
    store.want(c);
    ASSERT_TRUE(store.replace<CoarseLayer>(c, 0, initial).ok());
  }
  store.want(t11);
  const std::vector<uint16_t> edited(kTileSamples, 4321);
  ASSERT_TRUE(store.replace<CoarseLayer>(t11, 9, edited).ok());  // first held already edited

  const auto same = [&](std::span<const uint16_t> s) {
    return std::vector<uint16_t>(s.begin(), s.end()) == initial;
  };
  EXPECT_TRUE(same(store.initial_coarse(0, 0)));  // still at version 0: its own samples
  EXPECT_TRUE(store.initial_coarse(1, 1).empty());
  EXPECT_EQ(store.initial_tiles_kept(), 0u);

  // An event inside (0, 0), a whole region for (1, 0), a patch of (0, 1).
  wire::DeformEvent e;
  e.global_seq = 10;
  e.stamp = bump(w, 100, 100);
  e.base_versions = {{t00, 0}};
  ASSERT_EQ(store.on_event(e), EventOutcome::kApplied);
  ASSERT_TRUE(store.replace<CoarseLayer>(t10, 11, edited).ok());
  const std::vector<uint16_t> patch(16, 7);
  ASSERT_TRUE(store.patch<CoarseLayer>(t01, {0, 0, 4, 4}, 0, 12, patch).ok());
  EXPECT_EQ(store.initial_tiles_kept(), 3u);
  EXPECT_EQ(store.held_bytes(), size_t(4 + 3) * kTileSamples * 2);  // the copies count
  for (const auto& [tx, ty] : {std::pair{0, 0}, {1, 0}, {0, 1}}) {
    EXPECT_TRUE(same(store.initial_coarse(tx, ty))) << tx << "," << ty;
    EXPECT_FALSE(same(store.coarse_samples({Layer::kCoarse, 0, tx, ty}))) << tx << "," << ty;
  }
  // A second change keeps the first copy: version 0, not the version before.
  e.global_seq = 13;
  e.base_versions = {{t00, 10}};
  ASSERT_EQ(store.on_event(e), EventOutcome::kApplied);
  EXPECT_TRUE(same(store.initial_coarse(0, 0)));

  store.forget(t00);
  EXPECT_TRUE(store.initial_coarse(0, 0).empty());
  EXPECT_EQ(store.initial_tiles_kept(), 2u);

  // Off (the default): nothing is kept.
  ConfirmedStore plain(w);
  plain.want(t00);
  ASSERT_TRUE(plain.replace<CoarseLayer>(t00, 0, initial).ok());
  ASSERT_TRUE(plain.replace<CoarseLayer>(t00, 3, edited).ok());
  EXPECT_TRUE(plain.initial_coarse(0, 0).empty());
}

}  // namespace
}  // namespace loam::client
