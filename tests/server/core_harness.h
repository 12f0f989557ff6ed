// The replication core driven in process with a made-up clock, for its tests (core_*_test.cpp):
// no sockets, no timers. Frames come back as bytes and are decoded here, so each test states
// what every client receives, tick by tick. The tick's wait for its apply is the harness's
// (without a deadline), as the transport's would be.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <set>

#include "protocol/codec/region_codec.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/tile_rect.h"
#include "protocol/wire/framing.h"
#include "server/replication/replication_core.h"
#include "server/terrain_source.h"

namespace loam::server::core_test {

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
    // No snapshots unless a test asks for them.
    if (config.snapshot_every_stamps == ServerConfig{}.snapshot_every_stamps)
      config.snapshot_every_stamps = 0;
    if (config.snapshot_interval_s == ServerConfig{}.snapshot_interval_s) config.snapshot_interval_s = 0;
    // A tick waits for its stamps' apply (events in the same tick): deterministic tests. The
    // tests of the apply running past a tick set an apply wait of 0: the tick never waits.
    if (config.apply_wait_ms == ServerConfig{}.apply_wait_ms) config.apply_wait_ms = 60000;
    wait_for_apply_ = config.apply_wait_ms > 0;
    auto opened = open_storage(config.data_dir, "", config.stamp_limits, {}, {}, terrain);
    EXPECT_TRUE(opened.ok()) << (opened.ok() ? "" : opened.error().describe());
    core_ = std::make_unique<ReplicationCore>(config, std::move(*opened), now_);
  }
  ~CoreHarness() {
    core_.reset();
    std::filesystem::remove_all(dir_);
  }

  // The wall time the harness gives (Pong, new log segments).
  static constexpr UnixMicros kWall = 1'700'000'000'000'000;
  ReplicationCore& core() { return *core_; }
  const std::filesystem::path& dir() const { return dir_; }
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
      CoreOutput out = core_->take_output();
      for (const CoreLogLine& l : out.log) log_event(l.event, l.fields);
      for (const auto& [id, frame] : out.frames) {
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
    for (const CoreLogLine& l : out.log) log_event(l.event, l.fields);
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

  static inline int counter_ = 0;
  bool wait_for_apply_ = true;
  std::filesystem::path dir_;
  CoreTime now_ = CoreTime{} + 1000s;
  std::unique_ptr<ReplicationCore> core_;
  std::map<ClientId, Received> received_;
};

// The encoding a region's payload says it used (single-chunk regions).
inline RegionEncoding encoding_of(const wire::RegionUpdate& r) {
  EXPECT_EQ(r.chunk.size(), r.total_bytes);
  auto header = read_region_header(r.chunk);
  EXPECT_TRUE(header.ok());
  return header.ok() ? header->encoding : RegionEncoding::kRaw;
}

}  // namespace loam::server::core_test
