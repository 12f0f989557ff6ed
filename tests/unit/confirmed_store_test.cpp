// The client's confirmed store as a display follows it (client/net/confirmed_store.h): its
// change log lists regions and applied events in order with the samples they changed, and a
// region that arrives for a tile no longer wanted (sent before the Unsubscribe reached the
// server) is dropped rather than held stale.
#include "client/net/confirmed_store.h"

#include <gtest/gtest.h>

#include "protocol/stamps/stamp_apply.h"
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
  ASSERT_TRUE(store.replace_coarse(t00, 5, flat).ok());

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
  ASSERT_TRUE(store.replace_coarse(t10, 9, flat).ok());
  EXPECT_FALSE(store.holds(t10));
  EXPECT_EQ(store.counters().regions_unwanted, 1u);
  EXPECT_EQ(store.counters().regions, 0u);
}

}  // namespace
}  // namespace loam::client
