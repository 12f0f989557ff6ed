// The replication core (server/replication/replication_core.h) driven in process with a
// made-up clock: no sockets, no timers. Frames come back as bytes and are decoded here, so
// each test states what every client receives, tick by tick.
#include "server/replication/replication_core.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <set>

#include "protocol/codec/region_codec.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/tile_rect.h"
#include "protocol/wire/framing.h"
#include "server/terrain_source.h"

namespace loam::server {
namespace {

using namespace std::chrono_literals;

struct Received {
  std::vector<wire::Message> messages;
  uint64_t region_bytes = 0, event_bytes = 0, bytes = 0;
  template <typename T>
  std::vector<T> all() const {
    std::vector<T> out;
    for (const wire::Message& m : messages) {
      if (const T* t = std::get_if<T>(&m)) out.push_back(*t);
    }
    return out;
  }
};

class CoreHarness {
 public:
  explicit CoreHarness(ServerConfig config = {}, const std::string& terrain = kTerrainCrop) {
    dir_ = std::filesystem::temp_directory_path() /
           ("loam_core_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter_++));
    std::filesystem::remove_all(dir_);
    config.data_dir = dir_.string();
    config.snapshot_every_stamps = 0;
    config.snapshot_interval_s = 0;
    // A tick waits for its stamps' apply (events in the same tick): deterministic tests. The
    // tests of the apply running past a tick set an apply wait of 0: the tick never waits.
    if (config.apply_wait_ms == ServerConfig{}.apply_wait_ms) config.apply_wait_ms = 60000;
    wait_for_apply_ = config.apply_wait_ms > 0;
    auto opened = open_storage(config.data_dir, "", config.stamp_limits, {}, 0, terrain);
    EXPECT_TRUE(opened.ok()) << (opened.ok() ? "" : opened.error().describe());
    core_ = std::make_unique<ReplicationCore>(config, std::move(*opened), now_);
  }
  ~CoreHarness() {
    core_.reset();
    std::filesystem::remove_all(dir_);
  }

  ReplicationCore& core() { return *core_; }
  CoreTime now() const { return now_; }

  ClientId join(const std::string& name, wire::Role role = wire::Role::kPlayer) {
    const ClientId id = core_->connect("test:" + name, now_);
    wire::Hello h;
    h.client_name = name;
    h.requested_role = role;
    core_->receive(id, h, now_, kWall);
    collect();
    return id;
  }
  void send(ClientId id, const wire::Message& m) {
    core_->receive(id, m, now_, kWall);
    collect();
  }
  // One tick after `dt`; the transport reports nothing unsent (clients read at once).
  void tick(CoreClock::duration dt = 33333us) {
    now_ += dt;
    run_tick(*core_, now_, kWall, hooks());
    collect();
  }
  // One tick, with what the core hands the transport when the tick's acks are ready (before
  // it applies anything) kept apart, with the sequence applied by then.
  struct EarlyOutput {
    Received acks;
    uint64_t applied_seq = 0;
  };
  EarlyOutput tick_with_early_acks(CoreClock::duration dt = 33333us) {
    EarlyOutput early;
    now_ += dt;
    TickHooks with_acks = hooks();
    with_acks.acks_ready = [&] {
      early.applied_seq = core_->terrain().last_seq();
      for (const auto& [id, frame] : core_->take_output().frames) {
        wire::FrameAssembler a(wire::kAbsoluteMaxFrameBytes);
        a.feed(*frame);
        auto m = a.next_message();
        ASSERT_TRUE(m.ok() && m->has_value());
        early.acks.messages.push_back(std::move(**m));
      }
    };
    run_tick(*core_, now_, kWall, with_acks);
    collect();
    return early;
  }
  Received& of(ClientId id) { return received_[id]; }
  // Waits for the apply in flight and everything sequenced, and collects what it sent.
  void finish_applying() {
    core_->finish_applying();
    collect();
  }
  // Two players subscribed to every coarse tile, in sync at version 0, with nothing received.
  std::pair<ClientId, ClientId> two_players_in_sync() {
    const ClientId a = join("a"), b = join("b");
    send(a, subscribe_all(true));
    send(b, subscribe_all(true));
    tick();
    clear();
    return {a, b};
  }
  void clear() { received_.clear(); }

  // Every coarse tile of every mip, as held at the initial version 0 or not held.
  wire::Subscribe subscribe_all(bool held) const {
    wire::Subscribe sub;
    const WorldParams& p = core_->terrain().world().params();
    for (int32_t m = 0; m < p.mip_count(); ++m) {
      const RectI t = p.tile_range(m);
      for (int32_t ty = int32_t(t.y0); ty < t.y1; ++ty)
        for (int32_t tx = int32_t(t.x0); tx < t.x1; ++tx)
          sub.entries.push_back({TileCoord{Layer::kCoarse, uint8_t(m), tx, ty}, held, 0});
    }
    return sub;
  }

  // A stamp at (x, y) with `radius`, all in mip-0 samples.
  QuantizedStamp stamp(StampKind kind, double x, double y, double radius) const {
    const double mps = core_->terrain().world().params().meters_per_sample;
    StampParams s;
    s.kind = kind;
    s.center_x = x * mps;
    s.center_y = y * mps;
    s.radius = radius * mps;
    s.intensity = kind == StampKind::kFlatten ? 0.5 : 2.0;
    if (kind == StampKind::kCrater) s.shape = 0.3;
    if (kind == StampKind::kFlatten) s.target = 100;
    if (kind == StampKind::kShockwave) s.steps = 20, s.speed = 0.5, s.damping = 0.05;
    auto q = validate_stamp(s, core_->terrain().world().params(), core_->terrain().limits());
    EXPECT_TRUE(q.ok()) << (q.ok() ? "" : q.error().describe());
    return *q;
  }

 private:
  void collect() {
    CoreOutput out = core_->take_output();
    for (const auto& [id, frame] : out.frames) {
      wire::FrameAssembler a(wire::kAbsoluteMaxFrameBytes);
      a.feed(*frame);
      auto m = a.next_message();
      ASSERT_TRUE(m.ok() && m->has_value());
      Received& r = received_[id];
      r.bytes += frame->size();
      if (std::holds_alternative<wire::RegionUpdate>(**m)) r.region_bytes += frame->size();
      if (std::holds_alternative<wire::DeformEvent>(**m)) r.event_bytes += frame->size();
      r.messages.push_back(std::move(**m));
    }
  }

  // The tick's wait for its apply, as the transport would (without its deadline).
  TickHooks hooks() {
    TickHooks k;
    k.unsent = [](ClientId) { return uint64_t(0); };
    k.wait_for_apply = [this](ApplyWorker& w) {
      if (!wait_for_apply_) return false;
      w.wait();
      return true;
    };
    return k;
  }

  static constexpr UnixMicros kWall = 1'700'000'000'000'000;
  static inline int counter_ = 0;
  bool wait_for_apply_ = true;
  std::filesystem::path dir_;
  CoreTime now_ = CoreTime{} + 1000s;
  std::unique_ptr<ReplicationCore> core_;
  std::map<ClientId, Received> received_;
};

TEST(ReplicationCore, ClientsInSyncAtEveryMipGetTheEventAndNoRegionForPerSampleStamps) {
  CoreHarness h;
  const auto [a, b] = h.two_players_in_sync();
  const StampKind kinds[] = {StampKind::kGaussian, StampKind::kCrater, StampKind::kFootprint,
                             StampKind::kFlatten};
  uint32_t seq = 0;
  for (const StampKind k : kinds) {
    // At a four-tile corner, so mip-0 and coarser tiles all change.
    h.send(a, wire::Deform{++seq, h.stamp(k, 256.0, 256.0, 30.0)});
  }
  h.tick();
  for (const ClientId id : {a, b}) {
    EXPECT_EQ(h.of(id).all<wire::DeformEvent>().size(), 4u);
    EXPECT_TRUE(h.of(id).all<wire::RegionUpdate>().empty()) << "client " << id;
    EXPECT_EQ(h.core().tiles_of(id)->due_count(), 0u);
  }
  const auto acks = h.of(a).all<wire::DeformAck>();
  ASSERT_EQ(acks.size(), 4u);
  for (const auto& ack : acks) EXPECT_TRUE(ack.accepted);
  // Each event is a handful of bytes per changed tile.
  EXPECT_LT(h.of(b).event_bytes / 4, 100u);
}

TEST(ReplicationCore, ATicksAcksLeaveBeforeItsStampsAreAppliedAndEventsAfter) {
  CoreHarness h;
  const auto [a, b] = h.two_players_in_sync();
  // A costly shockwave from one client and a small crater from the other, in one tick.
  h.send(a, wire::Deform{1, h.stamp(StampKind::kShockwave, 300.0, 200.0, 40.0)});
  h.send(b, wire::Deform{1, h.stamp(StampKind::kCrater, 100.0, 100.0, 5.0)});
  const auto early = h.tick_with_early_acks();
  EXPECT_EQ(early.applied_seq, 0u) << "nothing applied when the acks are handed over";
  const auto acks = early.acks.all<wire::DeformAck>();
  ASSERT_EQ(acks.size(), 2u);
  EXPECT_TRUE(acks[0].accepted && acks[1].accepted);
  EXPECT_EQ(acks[0].global_seq, 1u);
  EXPECT_EQ(acks[1].global_seq, 2u);
  EXPECT_TRUE(early.acks.all<wire::DeformEvent>().empty());
  // The events follow once applied, at the sequence the acks promised.
  EXPECT_EQ(h.core().terrain().last_seq(), 2u);
  for (const ClientId id : {a, b}) {
    const auto events = h.of(id).all<wire::DeformEvent>();
    ASSERT_EQ(events.size(), 2u) << "client " << id;
    EXPECT_EQ(events[0].global_seq, 1u);
    EXPECT_EQ(events[1].global_seq, 2u);
    EXPECT_TRUE(h.of(id).all<wire::DeformAck>().empty());
  }
}

TEST(ReplicationCore, AStampStillApplyingHoldsNoAckOfTheNextTickAndEventsFollowInOrder) {
  ServerConfig config;
  config.apply_wait_ms = 0;  // a tick never waits for the apply
  config.max_stamp_cost = config.stamp_cost_per_second = 1ull << 40;
  CoreHarness h(config);
  const auto [a, b] = h.two_players_in_sync();
  // A detail-layer shockwave over much of the detail area, 256 steps: far longer to
  // apply than a tick.
  const WorldParams& w = h.core().terrain().world().params();
  const RectI d = w.detail_sample_rect();
  StampParams heavy;
  heavy.kind = StampKind::kShockwave;
  heavy.layer = Layer::kDetail;
  heavy.center_x = double(d.x0 + d.x1) / 2 * w.detail_meters_per_sample();
  heavy.center_y = double(d.y0 + d.y1) / 2 * w.detail_meters_per_sample();
  heavy.radius = 400 * w.detail_meters_per_sample();
  heavy.intensity = 0.5, heavy.speed = 0.5, heavy.damping = 0.01, heavy.steps = 256;
  auto q = validate_stamp(heavy, w, h.core().terrain().limits());
  ASSERT_TRUE(q.ok()) << q.error().describe();
  h.send(a, wire::Deform{1, *q});
  h.tick();
  ASSERT_EQ(h.of(a).all<wire::DeformAck>().size(), 1u);
  EXPECT_EQ(h.of(a).all<wire::DeformAck>()[0].global_seq, 1u);
  EXPECT_EQ(h.core().sequenced_seq(), 1u);
  EXPECT_EQ(h.core().published_seq(), 0u) << "the shockwave is still being applied";
  // The next tick: b's crater is sequenced and acknowledged while the shockwave runs, and a
  // client joining now continues from what was published.
  h.send(b, wire::Deform{1, h.stamp(StampKind::kCrater, 100.0, 100.0, 5.0)});
  h.tick();
  ASSERT_EQ(h.of(b).all<wire::DeformAck>().size(), 1u);
  EXPECT_EQ(h.of(b).all<wire::DeformAck>()[0].global_seq, 2u);
  const ClientId late = h.join("late");
  const auto welcome = h.of(late).all<wire::Welcome>();
  ASSERT_EQ(welcome.size(), 1u);
  EXPECT_EQ(welcome[0].global_sequence, h.core().published_seq());
  h.finish_applying();
  EXPECT_EQ(h.core().terrain().last_seq(), 2u);
  EXPECT_EQ(h.core().published_seq(), 2u);
  // The players hold coarse tiles only: the detail shockwave sends them nothing, the crater
  // its event, once the shockwave before it is applied.
  for (const ClientId id : {a, b}) {
    const auto events = h.of(id).all<wire::DeformEvent>();
    ASSERT_EQ(events.size(), 1u) << "client " << id;
    EXPECT_EQ(events[0].global_seq, 2u);
  }
}

// The core reads no clock and never blocks: a tick whose apply is still running says what it
// waits for (applying()), streams nothing, and the caller's wait decides when it goes on.
TEST(ReplicationCore, ATickWaitingForItsApplyNamesTheWorkerAndStreamsOnlyOnceTheCallerHasWaited) {
  ServerConfig config;
  config.apply_wait_ms = 0;
  config.max_stamp_cost = config.stamp_cost_per_second = 1ull << 40;
  CoreHarness h(config);
  const auto [a, b] = h.two_players_in_sync();
  // A detail shockwave over much of the detail area, 256 steps: far longer than a tick.
  const WorldParams& w = h.core().terrain().world().params();
  const RectI d = w.detail_sample_rect();
  StampParams heavy;
  heavy.kind = StampKind::kShockwave;
  heavy.layer = Layer::kDetail;
  heavy.center_x = double(d.x0 + d.x1) / 2 * w.detail_meters_per_sample();
  heavy.center_y = double(d.y0 + d.y1) / 2 * w.detail_meters_per_sample();
  heavy.radius = 400 * w.detail_meters_per_sample();
  heavy.intensity = 0.5, heavy.speed = 0.5, heavy.damping = 0.01, heavy.steps = 256;
  auto q = validate_stamp(heavy, w, h.core().terrain().limits());
  ASSERT_TRUE(q.ok()) << q.error().describe();
  h.send(a, wire::Deform{1, *q});
  TickHooks hooks;
  ApplyWorker* waited_on = nullptr;
  hooks.wait_for_apply = [&](ApplyWorker& worker) {
    waited_on = &worker;
    return false;  // the caller's deadline has passed: go on without the apply
  };
  const bool streamed = run_tick(h.core(), h.now() + 33ms, 0, hooks);
  // The tick streams exactly when it did not have to wait (a worker far quicker than usual).
  EXPECT_EQ(streamed, waited_on == nullptr);
  if (waited_on != nullptr) {
    EXPECT_EQ(waited_on, h.core().applying());
    EXPECT_EQ(h.core().published_seq(), 0u);
    waited_on->wait();
  }
  EXPECT_TRUE(h.core().advance_apply());
  EXPECT_EQ(h.core().applying(), nullptr);
  EXPECT_EQ(h.core().published_seq(), 1u);
  EXPECT_EQ(h.core().sequenced_seq(), 1u);
}

TEST(ReplicationCore, ShockwaveMipsTravelAsPatchesOverTheHeldVersion) {
  CoreHarness h;
  const ClientId a = h.join("a");
  h.send(a, h.subscribe_all(true));
  h.tick();
  h.clear();
  h.send(a, wire::Deform{1, h.stamp(StampKind::kShockwave, 300.0, 200.0, 4.0)});
  h.tick();
  const auto regions = h.of(a).all<wire::RegionUpdate>();
  ASSERT_FALSE(regions.empty());
  for (const auto& r : regions) {
    EXPECT_GT(r.tile.mip, 0);
    EXPECT_TRUE(r.patch);
    EXPECT_EQ(r.base_version, 0u);
    EXPECT_EQ(r.new_version, 1u);
  }
}

TEST(ReplicationCore, AShockwavesPatchesAreEncodedOnceForEveryClientInSync) {
  ServerConfig config;
  config.client_bytes_per_second = 0;
  CoreHarness h(config);
  std::vector<ClientId> ids;
  for (int i = 0; i < 6; ++i) ids.push_back(h.join("c" + std::to_string(i)));
  for (const ClientId id : ids) h.send(id, h.subscribe_all(true));
  h.tick();
  uint32_t seq = 0;
  for (int i = 0; i < 4; ++i) {
    const uint64_t before = h.core().region_counters().encodes;
    // Several in one tick, overlapping: the patches coalesce, the same way for every client.
    for (int j = 0; j < 4; ++j)
      h.send(ids[0], wire::Deform{++seq, h.stamp(StampKind::kShockwave, 200.0 + 40 * i + 9 * j, 300.0, 6.0)});
    h.tick();
    const size_t patches = h.of(ids[1]).all<wire::RegionUpdate>().size();
    for (const ClientId id : ids) EXPECT_EQ(h.of(id).all<wire::RegionUpdate>().size(), patches);
    EXPECT_EQ(h.core().region_counters().encodes - before, patches) << "shockwave " << i;
    h.clear();
  }
}

TEST(ReplicationCore, RegionsLeaveUnderTheClientsBudgetCoarsestMipFirst) {
  ServerConfig config;
  config.client_bytes_per_second = 128 << 10;
  CoreHarness h(config);
  const ClientId a = h.join("a");
  h.send(a, h.subscribe_all(false));
  const size_t tiles = h.core().tiles_of(a)->due_count();
  ASSERT_GT(tiles, 4u);
  int last_mip = 99;
  uint64_t sent_before = 0;
  int ticks = 0;
  while (h.core().tiles_of(a)->due_count() > 0 && ticks < 30 * 60) {
    h.tick();
    ++ticks;
    const uint64_t sent = h.of(a).region_bytes - sent_before;
    sent_before = h.of(a).region_bytes;
    // One tick's worth of credit, plus at most the one region that overdraws it.
    EXPECT_LE(sent, uint64_t(128 << 10) / 30 + 256 * 1024) << "tick " << ticks;
  }
  EXPECT_EQ(h.core().tiles_of(a)->due_count(), 0u);
  for (const auto& r : h.of(a).all<wire::RegionUpdate>()) {
    EXPECT_LE(r.tile.mip, last_mip);  // never a finer mip before a coarser one
    last_mip = r.tile.mip;
  }
  // The whole world took the time its bytes take at the budget (within a second's burst).
  const double seconds = ticks / 30.0;
  EXPECT_GE(seconds + 1.0, double(h.of(a).region_bytes) / double(128 << 10));
}

TEST(ReplicationCore, AJoinStormEncodesEachTileOnceForAllClients) {
  ServerConfig config;
  config.client_bytes_per_second = 0;  // no budget: all at once
  CoreHarness h(config);
  std::vector<ClientId> ids;
  for (int i = 0; i < 8; ++i) ids.push_back(h.join("c" + std::to_string(i)));
  for (const ClientId id : ids) h.send(id, h.subscribe_all(false));
  const size_t tiles = h.core().tiles_of(ids[0])->due_count();
  for (int i = 0; i < 200 && h.core().tiles_of(ids.back())->due_count() > 0; ++i) h.tick();
  for (const ClientId id : ids) EXPECT_EQ(h.core().tiles_of(id)->due_count(), 0u);
  EXPECT_EQ(h.core().region_counters().encodes, tiles);
  EXPECT_EQ(h.core().region_counters().hits, tiles * (ids.size() - 1));
}

TEST(ReplicationCore, EncodesPerTickAreBoundedSoATickStaysShort) {
  ServerConfig config;
  config.client_bytes_per_second = 0;
  config.max_encodes_per_tick = 3;
  CoreHarness h(config);
  const ClientId a = h.join("a");
  h.send(a, h.subscribe_all(false));
  h.tick();
  EXPECT_EQ(h.core().region_counters().encodes, 3u);
  h.tick();
  EXPECT_EQ(h.core().region_counters().encodes, 6u);
}

// On a generated base, an untouched tile's hash costs a refinement the first time: a hashes
// round makes a few and leaves the rest to later rounds, so a client subscribing a hundred new
// tiles does not stall the tick; every tile is hashed within a few rounds, and right.
TEST(ReplicationCore, AHashesRoundGeneratesAFewUntouchedTilesAndHashesTheRestInLaterRounds) {
  ServerConfig config;
  config.hashes_every_ticks = 1;
  config.prefetch_tiles = 0;
  CoreHarness h(config, kTerrainRefined);
  const ClientId a = h.join("a");
  wire::Subscribe sub;
  for (int32_t i = 0; i < 100; ++i)
    sub.entries.push_back({TileCoord{Layer::kCoarse, 0, 100 + i % 10, 100 + i / 10}, true, 0});
  h.send(a, sub);
  const World& w = h.core().terrain().world();
  std::map<TileCoord, uint64_t> hashed;
  int rounds = 0;
  while (hashed.size() < sub.entries.size() && rounds < 20) {
    h.clear();
    const uint64_t generated = w.base_tiles_generated();
    h.tick();
    ++rounds;
    EXPECT_LE(w.base_tiles_generated() - generated, 16u);
    size_t entries = 0;
    for (const wire::TileHashes& m : h.of(a).all<wire::TileHashes>()) {
      for (const wire::TileHashEntry& e : m.entries) {
        EXPECT_EQ(e.version, 0u);
        hashed[e.tile] = e.hash;
        ++entries;
      }
    }
    EXPECT_LE(entries, size_t(16 * rounds));  // the known ones again, and at most 16 new
  }
  EXPECT_EQ(hashed.size(), sub.entries.size());
  EXPECT_EQ(rounds, 7);  // 100 tiles, 16 a round
  for (const auto& [t, hash] : hashed) EXPECT_EQ(hash, w.tile_state(t).hash) << to_string(t);
}

TEST(ReplicationCore, UnacknowledgedDeformsAreCappedPerClientNotPerTick) {
  ServerConfig config;
  config.max_pending_deforms = 3;
  CoreHarness h(config);
  const ClientId a = h.join("a");
  for (uint32_t i = 1; i <= 4; ++i) h.send(a, wire::Deform{i, h.stamp(StampKind::kGaussian, 100, 100, 5)});
  auto acks = h.of(a).all<wire::DeformAck>();
  ASSERT_EQ(acks.size(), 1u);  // the fourth, refused at once
  EXPECT_FALSE(acks[0].accepted);
  EXPECT_EQ(acks[0].client_seq, 4u);
  EXPECT_EQ(acks[0].reject_code, wire::WireErrorCode::kTooManyPending);
  h.tick();  // the three are acknowledged: room again
  h.send(a, wire::Deform{5, h.stamp(StampKind::kGaussian, 100, 100, 5)});
  acks = h.of(a).all<wire::DeformAck>();
  ASSERT_EQ(acks.size(), 4u);
  for (size_t i = 1; i < 4; ++i) EXPECT_TRUE(acks[i].accepted);
  h.tick();
  EXPECT_EQ(h.of(a).all<wire::DeformAck>().size(), 5u);
  EXPECT_TRUE(h.of(a).all<wire::DeformAck>().back().accepted);
}

TEST(ReplicationCore, ARegionQueuedBehindTheBudgetLeavesAtTheTilesNewestVersion) {
  ServerConfig config;
  config.client_bytes_per_second = 1024;  // far below one tile a second
  CoreHarness h(config);
  const ClientId a = h.join("a"), editor = h.join("editor");
  h.send(a, h.subscribe_all(false));
  for (uint32_t i = 1; i <= 3; ++i)
    h.send(editor, wire::Deform{i, h.stamp(StampKind::kCrater, 100, 100, 10)});
  h.tick();
  // Nothing goes before credit accrues; then each region carries the version after all three.
  for (int i = 0; i < 30 * 120 && h.core().tiles_of(a)->due_count() > 0; ++i) h.tick();
  for (const auto& r : h.of(a).all<wire::RegionUpdate>()) {
    EXPECT_FALSE(r.patch);
    EXPECT_EQ(r.new_version, h.core().terrain().world().tile_state(r.tile).version);
  }
}

TEST(ReplicationCore, AClientResumingBehindGetsPatchesOfTheSamplesChangedSinceItsVersion) {
  ServerConfig config;
  config.client_bytes_per_second = 0;
  CoreHarness h(config);
  const ClientId editor = h.join("editor");
  for (uint32_t i = 1; i <= 5; ++i)
    h.send(editor, wire::Deform{i, h.stamp(StampKind::kCrater, 100.0 + 20 * i, 100.0, 8)});
  h.tick();
  // Back after the five stamps, holding every tile at the initial version.
  const ClientId back = h.join("back");
  h.send(back, h.subscribe_all(true));
  h.tick();
  const auto regions = h.of(back).all<wire::RegionUpdate>();
  ASSERT_FALSE(regions.empty());
  uint64_t samples = 0;
  for (const auto& r : regions) {
    EXPECT_TRUE(r.patch) << to_string(r.tile);
    EXPECT_EQ(r.base_version, 0u);
    EXPECT_EQ(r.new_version, h.core().terrain().world().tile_state(r.tile).version);
    samples += uint64_t(r.rect.area());
  }
  EXPECT_LT(samples, uint64_t(regions.size()) * kTileSamples / 8);
}

TEST(ReplicationCore, RequestsOverTheClientsRateAreDroppedWithOneErrorPerRun) {
  ServerConfig config;
  config.requests_per_second = 10;
  config.request_burst = 5;
  CoreHarness h(config);
  const ClientId a = h.join("a"), b = h.join("b");
  for (uint64_t i = 0; i < 20; ++i) h.send(a, wire::Ping{i});
  EXPECT_EQ(h.of(a).all<wire::Pong>().size(), 5u);
  auto errors = h.of(a).all<wire::ErrorMsg>();
  ASSERT_EQ(errors.size(), 1u);  // not one per refused request
  EXPECT_EQ(errors[0].code, wire::WireErrorCode::kRateLimited);
  EXPECT_EQ(h.core().stats().requests_refused, 15u);
  // Another client is not affected; the first gets its rate back as time passes.
  h.send(b, wire::Ping{1});
  EXPECT_EQ(h.of(b).all<wire::Pong>().size(), 1u);
  h.tick(300ms);
  for (uint64_t i = 0; i < 3; ++i) h.send(a, wire::Ping{100 + i});
  EXPECT_EQ(h.of(a).all<wire::Pong>().size(), 8u);
  EXPECT_EQ(h.of(a).all<wire::ErrorMsg>().size(), 1u);
  // Subscriptions draw on the same bucket.
  for (int i = 0; i < 10; ++i) h.send(a, h.subscribe_all(true));
  EXPECT_EQ(h.of(a).all<wire::ErrorMsg>().size(), 2u);
}

// Once a client has had a request refused for its rate, the transport stops reading it until
// its bucket holds a token again: a flood then waits in the flooder's socket instead of being
// decoded and dropped here. Other clients are never paused.
TEST(ReplicationCore, AClientOverItsRequestRateIsReadAgainWhenItsBucketRefills) {
  ServerConfig config;
  config.requests_per_second = 10;
  config.request_burst = 5;
  CoreHarness h(config);
  const ClientId a = h.join("a"), b = h.join("b");
  EXPECT_EQ(h.core().reads_paused_until(a, h.now()), std::nullopt);
  for (uint64_t i = 0; i < 5; ++i) h.send(a, wire::Ping{i});
  // The burst spent, but nothing refused yet: still read (the next request earns the Error).
  EXPECT_EQ(h.core().reads_paused_until(a, h.now()), std::nullopt);
  h.send(a, wire::Ping{5});
  ASSERT_EQ(h.of(a).all<wire::ErrorMsg>().size(), 1u);
  const auto until = h.core().reads_paused_until(a, h.now());
  ASSERT_TRUE(until.has_value());
  EXPECT_GT(*until, h.now());
  EXPECT_LE(*until, h.now() + 100ms);  // one token at 10 a second
  EXPECT_EQ(h.core().reads_paused_until(b, h.now()), std::nullopt);
  EXPECT_EQ(h.core().reads_paused_until(a, *until), std::nullopt);
  h.tick(100ms);
  h.send(a, wire::Ping{6});
  EXPECT_EQ(h.of(a).all<wire::Pong>().size(), 6u);
  EXPECT_EQ(h.core().reads_paused_until(a, h.now()), std::nullopt);  // admitted: no longer refused
}

TEST(ReplicationCore, StampsAreAdmittedByCostPerStampAndPerClient) {
  CoreHarness probe;  // the stamps' costs, to size the limits
  const WorldParams& p = probe.core().terrain().world().params();
  const QuantizedStamp wide = probe.stamp(StampKind::kGaussian, 300, 300, 60);
  const uint64_t wide_cost = *stamp_cost(wide, p);
  // A shockwave of many steps over a wide box.
  StampParams s;
  s.kind = StampKind::kShockwave;
  s.center_x = s.center_y = 400;
  s.radius = 20;
  s.intensity = 1;
  s.steps = 200;
  s.speed = 0.5;
  auto wave = validate_stamp(s, p, probe.core().terrain().limits());
  ASSERT_TRUE(wave.ok()) << wave.error().describe();
  const uint64_t wave_cost = *stamp_cost(*wave, p);
  ServerConfig config;
  config.max_stamp_cost = 10 * wide_cost;
  config.stamp_cost_per_second = wide_cost;  // a burst of ten, then one a second
  ASSERT_GT(wave_cost, config.max_stamp_cost);
  CoreHarness h(config);
  const ClientId heavy = h.join("heavy"), light = h.join("light");
  h.send(heavy, wire::Deform{1, *wave});
  for (uint32_t i = 0; i < 12; ++i) h.send(heavy, wire::Deform{2 + i, wide});
  // The light client's small stamps go through meanwhile: a bucket of its own.
  for (uint32_t i = 1; i <= 5; ++i) h.send(light, wire::Deform{i, h.stamp(StampKind::kCrater, 100, 100, 5)});
  h.tick();
  h.tick();
  size_t accepted = 0, over_limit = 0, over_budget = 0;
  for (const auto& a : h.of(heavy).all<wire::DeformAck>()) {
    accepted += a.accepted;
    if (!a.accepted && a.field == "stamp.cost") {
      over_limit += a.reject_code == wire::WireErrorCode::kOversize;
      over_budget += a.reject_code == wire::WireErrorCode::kRateLimited;
    }
  }
  EXPECT_EQ(over_limit, 1u);  // the shockwave
  EXPECT_EQ(accepted, 10u);
  EXPECT_EQ(over_budget, 2u);
  const auto light_acks = h.of(light).all<wire::DeformAck>();
  EXPECT_EQ(light_acks.size(), 5u);
  for (const auto& a : light_acks) EXPECT_TRUE(a.accepted);
}

TEST(ReplicationCore, ATickAppliesStampsUpToItsCostBudgetAndTheRestFollowInOrder) {
  ServerConfig config;
  CoreHarness probe;  // the stamps' cost, to size the budget
  const QuantizedStamp q = probe.stamp(StampKind::kGaussian, 300, 300, 40);
  const uint64_t cost = *stamp_cost(q, probe.core().terrain().world().params());
  config.tick_stamp_cost = 2 * cost;
  CoreHarness h(config);
  const ClientId a = h.join("a");
  for (uint32_t i = 1; i <= 5; ++i) h.send(a, wire::Deform{i, q});
  h.tick();
  EXPECT_EQ(h.of(a).all<wire::DeformAck>().size(), 2u);
  h.tick();
  EXPECT_EQ(h.of(a).all<wire::DeformAck>().size(), 4u);
  h.tick();
  const auto acks = h.of(a).all<wire::DeformAck>();
  ASSERT_EQ(acks.size(), 5u);
  for (uint32_t i = 0; i < 5; ++i) {
    EXPECT_TRUE(acks[i].accepted);
    EXPECT_EQ(acks[i].client_seq, i + 1);  // in order
    if (i > 0) {
      EXPECT_EQ(acks[i].global_seq, acks[i - 1].global_seq + 1);
    }
  }
}

TEST(ReplicationCore, DeformsResentAfterAReconnectAreAnsweredOnceAndAppliedOnce) {
  CoreHarness h;
  const auto hello = [&](ClientId id, const std::string& name, uint64_t key) {
    wire::Hello m;
    m.client_name = name;
    m.resume_key = key;
    h.send(id, m);
  };
  const QuantizedStamp s1 = h.stamp(StampKind::kCrater, 100, 100, 8),
                       s2 = h.stamp(StampKind::kGaussian, 200, 100, 8),
                       s3 = h.stamp(StampKind::kCrater, 300, 100, 8);
  const ClientId a = h.core().connect("test:a", h.now());
  hello(a, "a", 42);
  h.send(a, wire::Deform{1, s1});
  h.send(a, wire::Deform{2, s2});
  h.tick();  // both committed; a has their answers
  ASSERT_EQ(h.of(a).all<wire::DeformAck>().size(), 2u);
  const uint64_t seq2 = h.of(a).all<wire::DeformAck>()[1].global_seq;
  h.send(a, wire::Deform{3, s3});         // admitted, waiting for its tick...
  h.core().disconnected(a, "link lost");  // ...when the link goes
  // The client comes back with the same key and sends again what it never saw answered (and
  // one it did: its answer was lost on the way, say).
  const ClientId b = h.core().connect("test:b", h.now());
  hello(b, "a", 42);
  // The server still knows the key: resending is safe (after a restart it would say not).
  ASSERT_EQ(h.of(b).all<wire::Welcome>().size(), 1u);
  EXPECT_TRUE(h.of(b).all<wire::Welcome>()[0].resume_key_known);
  EXPECT_FALSE(h.of(a).all<wire::Welcome>()[0].resume_key_known);  // a new key at first
  h.send(b, wire::Deform{2, s2});
  h.send(b, wire::Deform{3, s3});
  const auto now_acks = h.of(b).all<wire::DeformAck>();
  ASSERT_EQ(now_acks.size(), 1u);  // 2: its first answer again, at once
  EXPECT_EQ(now_acks[0].client_seq, 2u);
  EXPECT_TRUE(now_acks[0].accepted);
  EXPECT_EQ(now_acks[0].global_seq, seq2);
  h.tick();  // 3 commits once, answered on the new connection
  const auto acks = h.of(b).all<wire::DeformAck>();
  ASSERT_EQ(acks.size(), 2u);
  EXPECT_EQ(acks[1].client_seq, 3u);
  EXPECT_TRUE(acks[1].accepted);
  EXPECT_EQ(acks[1].global_seq, 3u);
  EXPECT_EQ(h.core().terrain().last_seq(), 3u);  // three stamps, none twice
  EXPECT_EQ(h.core().stats().deforms_resent, 2u);
  // Another key's sequence numbers are its own; no key, no memory.
  const ClientId c = h.core().connect("test:c", h.now());
  hello(c, "c", 7);
  h.send(c, wire::Deform{2, s2});
  const ClientId d = h.join("d");
  h.send(d, wire::Deform{2, s2});
  h.send(d, wire::Deform{2, s2});
  h.tick();
  EXPECT_EQ(h.core().terrain().last_seq(), 6u);
}

TEST(ReplicationCore, ConnectionsInTheirHandshakeHaveAPoolOfTheirOwnPerAddress) {
  ServerConfig config;
  config.max_clients = 2;
  config.max_handshakes = 3;
  config.max_handshakes_per_address = 2;
  CoreHarness h(config);
  const CoreTime t = h.now();
  const ClientId x1 = h.core().connect("10.0.0.1:1001", t), x2 = h.core().connect("10.0.0.1:1002", t);
  const ClientId x3 = h.core().connect("10.0.0.1:1003", t);  // a third from the same address
  EXPECT_TRUE(h.core().in_handshake(x1));
  EXPECT_TRUE(h.core().in_handshake(x2));
  EXPECT_FALSE(h.core().in_handshake(x3));  // refused and closed
  const ClientId y1 = h.core().connect("10.0.0.2:2001", t);
  const ClientId z1 = h.core().connect("10.0.0.3:3001", t);  // the pool of three is full
  EXPECT_TRUE(h.core().in_handshake(y1));
  EXPECT_FALSE(h.core().in_handshake(z1));
  // Leaving the handshake frees a place: in session now, not in the pool.
  wire::Hello hello;
  hello.client_name = "x1";
  h.send(x1, hello);
  ASSERT_EQ(h.of(x1).all<wire::Welcome>().size(), 1u);
  const ClientId x4 = h.core().connect("10.0.0.1:1004", t);
  EXPECT_TRUE(h.core().in_handshake(x4));
  // Sessions are counted apart: two in session, the third Hello is refused as full.
  hello.client_name = "x2";
  h.send(x2, hello);
  EXPECT_EQ(h.of(x2).all<wire::Welcome>().size(), 1u);
  hello.client_name = "y1";
  h.send(y1, hello);
  EXPECT_TRUE(h.of(y1).all<wire::Welcome>().empty());
  const auto errors = h.of(y1).all<wire::ErrorMsg>();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].code, wire::WireErrorCode::kServerFull);
}

// The encoding a region's payload says it used (single-chunk regions).
RegionEncoding encoding_of(const wire::RegionUpdate& r) {
  EXPECT_EQ(r.chunk.size(), r.total_bytes);
  auto header = read_region_header(r.chunk);
  EXPECT_TRUE(header.ok());
  return header.ok() ? header->encoding : RegionEncoding::kRaw;
}

TEST(ReplicationCore, PatchesForAClientBehindAreDeltasAgainstTheSamplesItHolds) {
  ServerConfig config;
  config.client_bytes_per_second = 0;
  CoreHarness h(config);
  const World initial = h.core().terrain().world();
  const ClientId editor = h.join("editor");
  uint32_t seq = 0;
  for (int i = 0; i < 6; ++i) {
    h.send(editor, wire::Deform{++seq, h.stamp(StampKind::kCrater, 200.0 + 15 * i, 250.0 + 3 * i, 12)});
    h.send(editor, wire::Deform{++seq, h.stamp(StampKind::kGaussian, 240.0, 200.0 + 20 * i, 9)});
    h.tick();
  }
  const ClientId back = h.join("back");
  h.send(back, h.subscribe_all(true));  // holds everything at version 0
  h.tick();
  const World& now = h.core().terrain().world();
  const auto regions = h.of(back).all<wire::RegionUpdate>();
  ASSERT_FALSE(regions.empty());
  for (const auto& r : regions) {
    ASSERT_TRUE(r.patch);
    EXPECT_EQ(encoding_of(r), RegionEncoding::kDelta) << to_string(r.tile);
    // Decoded against the samples held at version 0, it gives the samples now.
    const auto held = copy_tile_rect(initial.coarse_tile(r.tile.mip, r.tile.tx, r.tile.ty), r.rect);
    auto decoded = decode_region(r.chunk, uint32_t(r.rect.width()), uint32_t(r.rect.height()),
                                 RegionRefs<uint16_t>{.base = held, .coarser = {}});
    ASSERT_TRUE(decoded.ok()) << decoded.error().describe();
    EXPECT_EQ(*decoded, copy_tile_rect(now.coarse_tile(r.tile.mip, r.tile.tx, r.tile.ty), r.rect))
        << to_string(r.tile);
  }
  EXPECT_EQ(h.core().region_counters().delta_encodes, regions.size());
}

TEST(ReplicationCore, AWholeTileSentToManyIsReencodedInTheBestModeOffTheTick) {
  ServerConfig config;
  config.client_bytes_per_second = 0;
  config.best_after_uses = 2;
  CoreHarness h(config);
  const ClientId a = h.join("a"), b = h.join("b");
  h.send(a, h.subscribe_all(false));
  h.send(b, h.subscribe_all(false));
  for (int i = 0; i < 100 && h.core().tiles_of(b)->due_count() > 0; ++i) h.tick();
  const uint64_t fast_bytes = h.of(b).region_bytes;
  h.core().finish_background_encodes();
  const RegionFrameCounters rc = h.core().region_counters();
  EXPECT_GT(rc.best_upgrades, 0u);
  EXPECT_GT(rc.best_bytes_saved, 0u);
  EXPECT_LT(rc.best_bytes_saved, fast_bytes / 4);  // a few percent: the fast mode is close
  // The cache holds every tile once, at its smaller size.
  EXPECT_EQ(rc.bytes_held, fast_bytes - rc.best_bytes_saved);
  // A third client gets the smaller frames, and they decode to the same tiles.
  const ClientId c = h.join("c");
  h.send(c, h.subscribe_all(false));
  for (int i = 0; i < 100 && h.core().tiles_of(c)->due_count() > 0; ++i) h.tick();
  EXPECT_EQ(h.of(c).region_bytes + rc.best_bytes_saved, fast_bytes);
  size_t best = 0;
  const World& w = h.core().terrain().world();
  for (const auto& r : h.of(c).all<wire::RegionUpdate>()) {
    if (encoding_of(r) == RegionEncoding::kBest) ++best;
    auto decoded = decode_region(r.chunk, kTileSize, kTileSize);
    ASSERT_TRUE(decoded.ok());
    const auto tile = w.coarse_tile(r.tile.mip, r.tile.tx, r.tile.ty);
    EXPECT_TRUE(std::equal(decoded->begin(), decoded->end(), tile.begin(), tile.end()));
  }
  EXPECT_EQ(best, rc.best_upgrades);
}

TEST(TileHistory, SamplesAtAVersionAreRebuiltByUndoingEveryLaterChange) {
  WorldParams p;
  p.tiles_x = 3;
  p.tiles_y = 2;
  World world(p, 20000);
  TileHistory history(64, 64);
  std::map<uint64_t, World> at;  // the world after each stamp
  at.emplace(0, world);
  StampParams s;
  s.kind = StampKind::kCrater;
  s.radius = 40;
  s.intensity = 3;
  s.shape = 0.3;
  for (uint64_t seq = 1; seq <= 8; ++seq) {
    // Around the corner of four tiles and along the world's edge.
    s.center_x = seq % 2 ? 256.0 + 9.0 * double(seq) : 760.0;
    s.center_y = seq % 2 ? 250.0 : 20.0 * double(seq);
    auto q = validate_stamp(s, p, {});
    ASSERT_TRUE(q.ok());
    auto reach = stamp_reach(*q, p);
    ASSERT_TRUE(reach.ok());
    const auto before = read_reach(world, Layer::kCoarse, *reach, 1u << 24);
    ASSERT_FALSE(before.empty());
    ASSERT_TRUE(apply_stamp(world, *q).ok());
    history.record(world.commit(seq), before);
    at.emplace(seq, world);
  }
  size_t checked = 0;
  for (int32_t m = 0; m < p.mip_count(); ++m) {
    const RectI tiles = p.tile_range(m);
    for (int32_t ty = int32_t(tiles.y0); ty < tiles.y1; ++ty) {
      for (int32_t tx = int32_t(tiles.x0); tx < tiles.x1; ++tx) {
        const TileCoord c{Layer::kCoarse, uint8_t(m), tx, ty};
        for (const auto& [held, old] : at) {
          if (old.tile_state(c).version != held) continue;  // not a version this tile had
          const auto rect = history.changed_since(c, held);
          if (!rect || rect->empty()) continue;
          const auto now = copy_tile_rect(world.coarse_tile(m, tx, ty), *rect);
          const auto rebuilt = history.coarse_at(c, held, *rect, now);
          ASSERT_TRUE(rebuilt.has_value()) << to_string(c) << " at " << held;
          EXPECT_EQ(*rebuilt, copy_tile_rect(old.coarse_tile(m, tx, ty), *rect))
              << to_string(c) << " at " << held;
          ++checked;
        }
      }
    }
  }
  EXPECT_GT(checked, 20u);
  // Over its byte bound the history forgets the least recently changed tiles: no samples,
  // no rect, and the client gets the whole tile.
  TileHistory small(64, 64, 1024);
  WorldParams one;
  World w1(one, 100);
  s.center_x = s.center_y = 128;
  auto q = validate_stamp(s, one, {});
  ASSERT_TRUE(q.ok());
  const auto before = read_reach(w1, Layer::kCoarse, *stamp_reach(*q, one), 1u << 24);
  ASSERT_TRUE(apply_stamp(w1, *q).ok());
  small.record(w1.commit(1), before);
  EXPECT_LE(small.bytes(), 1024u);
  EXPECT_EQ(small.coarse_at(TileCoord{}, 0, RectI{0, 0, 1, 1}, std::vector<uint16_t>{100}), std::nullopt);
}

TEST(TileHistory, ChangedSinceUnitesTheRectsAfterTheHeldVersionOrSaysUnknown) {
  TileHistory history(3, 2);
  const TileCoord a{Layer::kCoarse, 0, 0, 0}, b{Layer::kCoarse, 0, 1, 0}, c{Layer::kCoarse, 0, 2, 0};
  const std::vector<TileChange> changes = {{a, {0, 0, 4, 4}, 0, 3},
                                           {a, {10, 10, 12, 12}, 3, 7},
                                           {a, {2, 2, 3, 3}, 7, 9},
                                           {a, {50, 50, 51, 51}, 9, 11}};
  history.record(changes);
  EXPECT_EQ(history.changed_since(a, 11), RectI{});               // current
  EXPECT_EQ(history.changed_since(a, 7), (RectI{2, 2, 51, 51}));  // two changes since
  EXPECT_EQ(history.changed_since(a, 3), (RectI{2, 2, 51, 51}));  // three (the oldest kept)
  EXPECT_EQ(history.changed_since(a, 0), std::nullopt);           // beyond what is kept
  EXPECT_EQ(history.changed_since(b, 0), std::nullopt);           // never changed here
  const std::vector<TileChange> more = {{b, {0, 0, 1, 1}, 0, 12}, {c, {0, 0, 1, 1}, 0, 13}};
  history.record(more);  // two tiles at most: a, the least recently changed, goes
  EXPECT_EQ(history.changed_since(a, 9), std::nullopt);
  EXPECT_EQ(history.changed_since(c, 0), (RectI{0, 0, 1, 1}));
}

}  // namespace
}  // namespace loam::server
