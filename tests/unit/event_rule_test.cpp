// The rule server and client share for a DeformEvent (protocol/replication/event_rule.h), as a
// table: held versions x event tiles x mip x kind -> apply or wait, and which tiles follow the
// event. The server's planner sends regions exactly for the held tiles that do not follow it.
#include "protocol/replication/event_rule.h"

#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

namespace loam::replication {
namespace {

constexpr TileCoord c0{Layer::kCoarse, 0, 0, 0};
constexpr TileCoord c0b{Layer::kCoarse, 0, 1, 0};
constexpr TileCoord c1{Layer::kCoarse, 1, 0, 0};
constexpr TileCoord c3{Layer::kCoarse, 3, 0, 0};
constexpr TileCoord d0{Layer::kDetail, 0, 0, 0};

struct Row {
  std::string what;
  StampKind kind;
  Layer layer;
  std::vector<wire::TileVersion> event_tiles;  // base versions, event seq 10
  std::map<TileCoord, uint64_t> held;
  EventFit fit;
  std::vector<TileCoord> follows;  // held tiles the event reproduces
};

wire::DeformEvent event(const Row& r) {
  wire::DeformEvent e;
  e.global_seq = 10;
  e.stamp.kind = r.kind;
  e.stamp.layer = r.layer;
  e.base_versions = r.event_tiles;
  return e;
}

TEST(EventRule, TableOfHeldVersionsEventTilesMipsAndKinds) {
  const std::vector<Row> rows = {
      {"mip-0 tile held at its base: apply",
       StampKind::kGaussian,
       Layer::kCoarse,
       {{c0, 4}},
       {{c0, 4}},
       EventFit::kApply,
       {c0}},
      {"mip-0 tile held behind its base: wait",
       StampKind::kGaussian,
       Layer::kCoarse,
       {{c0, 4}},
       {{c0, 3}},
       EventFit::kWait,
       {}},
      {"mip-0 tile held ahead of its base (a newer region came first): wait",
       StampKind::kCrater,
       Layer::kCoarse,
       {{c0, 4}},
       {{c0, 9}},
       EventFit::kWait,
       {}},
      {"only coarse mips held, at their bases: apply there",
       StampKind::kCrater,
       Layer::kCoarse,
       {{c0, 4}, {c1, 4}, {c3, 2}},
       {{c1, 4}, {c3, 2}},
       EventFit::kApply,
       {c1, c3}},
      {"a held mip behind its base stops the whole event",
       StampKind::kFlatten,
       Layer::kCoarse,
       {{c0, 4}, {c1, 4}, {c3, 2}},
       {{c0, 4}, {c1, 4}, {c3, 1}},
       EventFit::kWait,
       {}},
      {"footprint: one tile of two under the foot held is enough (contact travels)",
       StampKind::kFootprint,
       Layer::kCoarse,
       {{c0, 4}, {c0b, 0}, {c1, 4}},
       {{c0, 4}},
       EventFit::kApply,
       {c0}},
      {"texture at every mip",
       StampKind::kTexture,
       Layer::kCoarse,
       {{c0, 0}, {c1, 0}},
       {{c0, 0}, {c1, 0}},
       EventFit::kApply,
       {c0, c1}},
      {"shockwave: mip 0 follows, its mips come as regions",
       StampKind::kShockwave,
       Layer::kCoarse,
       {{c0, 4}, {c1, 4}},
       {{c0, 4}, {c1, 4}},
       EventFit::kApply,
       {c0}},
      {"shockwave: a mip held at another version does not matter",
       StampKind::kShockwave,
       Layer::kCoarse,
       {{c0, 4}, {c1, 4}},
       {{c0, 4}, {c1, 2}},
       EventFit::kApply,
       {c0}},
      {"detail stamp: the detail tile follows",
       StampKind::kGaussian,
       Layer::kDetail,
       {{d0, 6}},
       {{d0, 6}},
       EventFit::kApply,
       {d0}},
      {"nothing held: apply (consumed, no change)",
       StampKind::kGaussian,
       Layer::kCoarse,
       {{c0, 4}, {c1, 4}},
       {},
       EventFit::kApply,
       {}},
      {"no tiles listed (too many for one event): wait for regions",
       StampKind::kGaussian,
       Layer::kCoarse,
       {},
       {{c0, 4}},
       EventFit::kWait,
       {}},
  };
  for (const Row& r : rows) {
    SCOPED_TRACE(r.what);
    const wire::DeformEvent e = event(r);
    const auto held = [&](const TileCoord& c) -> std::optional<uint64_t> {
      const auto it = r.held.find(c);
      if (it == r.held.end()) return std::nullopt;
      return it->second;
    };
    EXPECT_EQ(event_fit(e, held), r.fit);
    std::vector<TileCoord> follows;
    if (event_fit(e, held) == EventFit::kApply) {
      for (const wire::TileVersion& bv : e.base_versions) {
        if (r.held.count(bv.tile) && event_reproduces_tile(e.stamp, bv.tile)) follows.push_back(bv.tile);
      }
    }
    EXPECT_EQ(follows, r.follows);
  }
}

TEST(EventRule, NoStampReproducesATileOfTheOtherLayer) {
  QuantizedStamp q;
  for (int k = 0; k < kStampKindCount; ++k) {
    q.kind = StampKind(k);
    q.layer = Layer::kDetail;
    EXPECT_FALSE(event_reproduces_tile(q, c0));
    EXPECT_FALSE(event_reproduces_tile(q, c1));
    q.layer = Layer::kCoarse;
    EXPECT_FALSE(event_reproduces_tile(q, d0));
    EXPECT_TRUE(event_reproduces_tile(q, c0));
    EXPECT_EQ(event_reproduces_tile(q, c3), q.kind != StampKind::kShockwave);
  }
}

}  // namespace
}  // namespace loam::replication
