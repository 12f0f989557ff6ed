// What the replication core sends, pinned byte for byte: a scripted session (clients joining,
// refused and timing out, stamps of every kind on both layers, subscriptions held and not,
// rate limits, a reconnect that resumes its Deforms and its tiles, snapshots, stats, shutdown)
// driven with a made-up clock, and every output written to a transcript: each frame to each
// client (type, size, a hash of its bytes), each close, the deformation log's records, the
// stats log line and the other core log lines (timings and wall times left out), the Stats
// message and the /metrics text. The transcript is compared with the committed one, so a
// change that moves behaviour, however small, fails here and names the first line that moved.
//
// Regenerate (only when a change of behaviour is intended, and say so in the commit):
//   LOAM_REGENERATE_GOLDEN=1 build/<dir>/tests/loam_server_tests --gtest_filter='CoreTranscript.*'
// which rewrites tests/golden/server/core_transcript.txt in the source tree.
//
// Deterministic by construction: the clock is the script's, the tick waits for its apply, the
// best-mode re-encodes are finished before every tick, snapshots are written on the tick
// thread, the prefetcher is off, and Pong's wall time is zeroed before hashing.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "protocol/hex64.h"
#include "protocol/log/log_file.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/wire/framing.h"
#include "server/metrics.h"
#include "server/replication/replication_core.h"
#include "server/storage.h"

namespace loam::server {
namespace {

using namespace std::chrono_literals;

constexpr const char* kGoldenPath = LOAM_SOURCE_DIR "/tests/golden/server/core_transcript.txt";
constexpr const char* kEditorToken = "00112233445566778899aabbccddeeff";
constexpr const char* kViewerToken = "ffeeddccbbaa99887766554433221100";

uint64_t fnv1a(std::span<const uint8_t> bytes) {
  uint64_t h = 14695981039346656037ull;
  for (const uint8_t b : bytes) h = (h ^ b) * 1099511628211ull;
  return h;
}

// Log kinds a client can cause are rate-limited by the wall clock (event_log.h): their lines
// may be dropped, so the transcript leaves them out (their frames and counters are in it).
bool rate_limited_kind(const std::string& kind) {
  static const char* const kinds[] = {"connect",      "disconnect",          "hello",        "reject",
                                      "violation",    "deform_rejected",     "client_error", "drop",
                                      "tick_overrun", "tls_handshake_failed"};
  for (const char* k : kinds)
    if (kind == k) return true;
  return false;
}

// One `loam-server ts=… event=… k=v …` line without its wall time, its durations (fields
// named ms or *_ms) and the test's temporary folder; empty for lines left out.
std::string normalized_log_line(const std::string& line, const std::string& data_dir) {
  const std::string prefix = "loam-server ts=";
  if (line.rfind(prefix, 0) != 0) return {};
  std::vector<std::string> tokens;
  std::string cur;
  bool quoted = false;
  for (const char c : line.substr(prefix.size())) {
    if (c == '"') quoted = !quoted;
    if (c == ' ' && !quoted) {
      tokens.push_back(std::exchange(cur, {}));
      continue;
    }
    cur += c;
  }
  if (!cur.empty()) tokens.push_back(cur);
  std::string out;
  std::string kind;
  for (size_t i = 1; i < tokens.size(); ++i) {  // tokens[0] is the timestamp
    const size_t eq = tokens[i].find('=');
    const std::string key = tokens[i].substr(0, eq);
    std::string value = eq == std::string::npos ? "" : tokens[i].substr(eq + 1);
    if (key == "event") kind = value;
    if (key == "suppressed") continue;
    if (key == "ms" || (key.size() > 3 && key.ends_with("_ms") && !key.starts_with("tick_p"))) value = "*";
    for (size_t at; (at = value.find(data_dir)) != std::string::npos;)
      value.replace(at, data_dir.size(), "$DATA");
    out += (out.empty() ? "" : " ") + key + "=" + value;
  }
  if (rate_limited_kind(kind)) return {};
  return out;
}

class Transcript {
 public:
  explicit Transcript(ServerConfig config) {
    dir_ = std::filesystem::temp_directory_path() / ("loam_core_transcript_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    config.data_dir = dir_.string();
    auto opened = open_storage(config.data_dir, "", config.stamp_limits, {}, {}, kTerrainCrop);
    EXPECT_TRUE(opened.ok()) << (opened.ok() ? "" : opened.error().describe());
    // A 16x16 ramp, registered before the core starts, for the texture stamp.
    std::vector<uint16_t> ramp(16 * 16);
    for (size_t i = 0; i < ramp.size(); ++i) ramp[i] = uint16_t((i * 257) & 0xffff);
    auto id = opened->terrain.textures().add(16, 16, ramp);
    EXPECT_TRUE(id.ok());
    texture_id_ = *id;
    core_ = std::make_unique<ReplicationCore>(config, std::move(*opened), now_, &counters_);
  }
  ~Transcript() {
    core_.reset();
    std::filesystem::remove_all(dir_);
  }

  ReplicationCore& core() { return *core_; }
  CoreTime now() const { return now_; }
  uint64_t texture_id() const { return texture_id_; }
  std::string data_dir() const { return dir_.string(); }
  std::vector<std::string>& lines() { return lines_; }
  // As the transport reports: its largest send queue, then the stats line or the metrics.
  void report_stats(uint64_t max_queue_bytes) {
    counters_.max_queue_bytes = max_queue_bytes;
    flush_suppressed_log_lines();
    core_->report_stats(now_);
    collect();
  }
  std::string metrics_text(uint64_t max_queue_bytes) {
    counters_.max_queue_bytes = max_queue_bytes;
    return prometheus_text(core_->metrics());
  }

  void step(const std::string& what) { lines_.push_back("# " + what); }

  ClientId connect(const std::string& peer) {
    const ClientId id = core_->connect(peer, now_);
    lines_.push_back("connect " + peer + " -> c" + std::to_string(id));
    collect();
    return id;
  }
  // The frame's bytes as the transport counts them coming in.
  void send(ClientId id, const wire::Message& m) {
    auto frame = wire::encode_frame(m, wire::kAbsoluteMaxFrameBytes);
    ASSERT_TRUE(frame.ok());
    counters_.bytes_in += frame->size();
    core_->receive(id, m, now_, kWall);
    collect();
  }
  ClientId join(const std::string& name, const std::string& peer, const char* token, uint64_t key = 0,
                wire::Role role = wire::Role::kPlayer) {
    const ClientId id = connect(peer);
    wire::Hello h;
    h.client_name = name;
    h.requested_role = role;
    h.resume_key = key;
    if (token) h.access_token = *wire::parse_access_token(token);
    send(id, h);
    return id;
  }
  void disconnected(ClientId id, const std::string& why) {
    core_->disconnected(id, why);
    lines_.push_back("disconnected c" + std::to_string(id));
    collect();
  }
  void timed_out(ClientId id, bool handshake) {
    core_->timed_out(id, handshake);
    collect();
  }
  void stream_error(ClientId id) {
    core_->stream_error(id, make_error(ErrorCode::kCorrupt, "frame.length", "scripted bad frame"));
    collect();
  }
  // One tick `dt` after the last, then the tick's duration as the transport would measure it.
  void tick(CoreClock::duration dt, double tick_ms) {
    now_ += dt;
    core_->finish_background_encodes();  // best-mode encodes adopted at a known point
    lines_.push_back("tick " + std::to_string(core_->tick_count() + 1));
    TickHooks hooks;
    hooks.unsent = [&](ClientId id) { return unsent_.contains(id) ? unsent_.at(id) : uint64_t(0); };
    hooks.acks_ready = [&] {
      lines_.push_back(" acks_ready");
      collect();
    };
    hooks.wait_for_apply = [](ApplyWorker& w) {
      w.wait();
      return true;
    };
    run_tick(*core_, now_, kWall, hooks);
    collect();
    core_->record_tick({.total_ms = tick_ms});
    collect();
    std::string due;
    for (ClientId id = 1; id < 64; ++id) {
      if (const ClientTiles* t = core_->tiles_of(id))
        due += " c" + std::to_string(id) + "=" + std::to_string(t->due_count());
    }
    lines_.push_back(" seq " + std::to_string(core_->sequenced_seq()) + "/" +
                     std::to_string(core_->published_seq()) + " due" + due);
  }
  void set_unsent(ClientId id, uint64_t bytes) { unsent_[id] = bytes; }
  void advance(CoreClock::duration dt) { now_ += dt; }

  QuantizedStamp stamp(StampKind kind, double x, double y, double radius, Layer layer = Layer::kCoarse) {
    const WorldParams& p = core_->terrain().world().params();
    StampParams s;
    s.kind = kind;
    s.layer = layer;
    s.center_x = x * p.meters_per_sample;
    s.center_y = y * p.meters_per_sample;
    s.radius = radius * p.meters_per_sample;
    s.intensity = layer == Layer::kDetail ? 0.3 : kind == StampKind::kFlatten ? 0.5 : 2.0;
    s.rotation = 0.4;
    if (kind == StampKind::kCrater) s.shape = 0.3, s.volume_conserving = true;
    if (kind == StampKind::kFlatten) s.target = 100;
    if (kind == StampKind::kShockwave) s.steps = 12, s.speed = 0.5, s.damping = 0.05;
    if (kind == StampKind::kTexture) s.texture_id = texture_id_;
    auto q = validate_stamp(s, p, core_->terrain().limits(), &core_->terrain().textures());
    EXPECT_TRUE(q.ok()) << (q.ok() ? "" : q.error().describe());
    return q.ok() ? *q : QuantizedStamp{};
  }

  // Every coarse tile of every mip, held at version 0 or not held.
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

  // As the transport does: the frames, the closes, and the core's log lines written.
  void collect() {
    CoreOutput out = core_->take_output();
    for (const CoreLogLine& l : out.log) log_event(l.event, l.fields);
    for (const auto& [id, frame] : out.frames) {
      wire::FrameAssembler a(wire::kAbsoluteMaxFrameBytes);
      a.feed(*frame);
      auto m = a.next_message();
      ASSERT_TRUE(m.ok() && m->has_value());
      std::vector<uint8_t> bytes = *frame;
      // Pong carries the server's wall time: zeroed, the rest of the frame is pinned.
      if (auto* pong = std::get_if<wire::Pong>(&**m)) {
        pong->server_time_us = 0;
        bytes = *wire::encode_frame(**m, wire::kAbsoluteMaxFrameBytes);
      }
      counters_.bytes_out += frame->size();
      lines_.push_back("  c" + std::to_string(id) + " " + wire::to_string(wire::message_type(**m)) + " " +
                       std::to_string(frame->size()) + " " + hex64(fnv1a(bytes)));
    }
    for (const auto& [id, reason] : out.closes)
      lines_.push_back("  close c" + std::to_string(id) + " " + reason);
  }

 private:
  static constexpr UnixMicros kWall = 1'700'000'000'000'000;  // Pong's (zeroed before hashing)
  std::filesystem::path dir_;
  TransportCounters counters_;  // what the transport would count: the frames' bytes
  CoreTime now_ = CoreTime{} + 1000s;
  std::unique_ptr<ReplicationCore> core_;
  uint64_t texture_id_ = 0;
  std::map<ClientId, uint64_t> unsent_;
  std::vector<std::string> lines_;
};

ServerConfig scripted_config() {
  ServerConfig c;
  c.editor_tokens = {kEditorToken};
  c.viewer_tokens = {kViewerToken};
  c.max_clients = 5;
  c.max_handshakes = 8;
  c.max_handshakes_per_address = 3;
  c.max_pending_deforms = 4;
  c.deforms_per_second = 10;
  c.deform_burst = 7;
  c.requests_per_second = 5;
  c.request_burst = 6;
  c.tick_stamp_cost = 20000;
  c.client_bytes_per_second = 48u << 10;
  c.max_encodes_per_tick = 6;
  c.best_after_uses = 2;
  c.hashes_every_ticks = 4;
  c.snapshot_every_stamps = 7;
  c.snapshot_interval_s = 2.0;
  c.async_snapshots = false;
  c.prefetch_tiles = 0;
  c.apply_wait_ms = 60000;  // every tick waits for its apply: events leave in the tick
  c.stats_interval_s = 0;
  return c;
}

// The script. Lines it adds are the behaviour pinned; change it only with the golden.
std::vector<std::string> run_script() {
  Transcript s(scripted_config());
  const CoreClock::duration tick = 33333us;
  testing::internal::CaptureStderr();

  s.step("admission: editor, viewer, refused, wrong version, no Hello, handshake pool");
  const ClientId a = s.join("alice", "10.0.0.1:1000", kEditorToken, 42);
  const ClientId b = s.join("bob", "10.0.0.2:1000", kViewerToken);
  s.join("carol", "10.0.0.3:1", nullptr);
  s.join("dave", "10.0.0.4:1", "0123456789abcdef0123456789abcdef");  // a wrong token
  {
    const ClientId e = s.connect("10.0.0.5:1");
    wire::Hello h;
    h.version_major = wire::kProtocolMajor + 1;
    h.access_token = *wire::parse_access_token(kEditorToken);
    s.send(e, h);
    const ClientId f = s.connect("10.0.0.6:1");
    s.send(f, wire::Ping{7});
    const ClientId g = s.connect("10.0.0.7:1");
    s.timed_out(g, false);  // a stale idle timer: ignored
    s.timed_out(g, true);
    std::vector<ClientId> same;
    for (int i = 0; i < 4; ++i) same.push_back(s.connect("10.0.0.8:" + std::to_string(i)));
    for (const ClientId id : same) s.disconnected(id, "gone");
  }

  s.step("subscriptions: alice holds every coarse tile and four detail tiles, bob holds none");
  {
    wire::Subscribe sub = s.subscribe_all(true);
    const WorldParams& p = s.core().terrain().world().params();
    const int32_t dt = int32_t(300 * p.detail_factor / kTileSize);
    for (int32_t y = dt; y < dt + 2; ++y)
      for (int32_t x = dt; x < dt + 2; ++x)
        sub.entries.push_back({TileCoord{Layer::kDetail, 0, x, y}, true, 0});
    sub.focus = wire::Focus{300 * p.meters_per_sample, 300 * p.meters_per_sample};
    s.send(a, sub);
    wire::Subscribe all = s.subscribe_all(false);
    all.focus = wire::Focus{0, 0};
    s.send(b, all);
    s.send(b, wire::Subscribe{{{TileCoord{Layer::kCoarse, 0, 900, 900}, false, 0}}, std::nullopt});
  }
  s.tick(tick, 4.0);
  s.tick(tick, 4.5);

  s.step("stamps of every kind, the pending cap, a viewer's and an invalid one");
  uint32_t seq = 0;
  s.send(a, wire::Deform{++seq, s.stamp(StampKind::kTexture, 256, 256, 20)});
  s.send(a, wire::Deform{++seq, s.stamp(StampKind::kGaussian, 300, 260, 30)});
  s.send(a, wire::Deform{++seq, s.stamp(StampKind::kCrater, 250, 300, 25)});
  s.send(a, wire::Deform{++seq, s.stamp(StampKind::kFootprint, 400, 200, 10)});
  s.send(a, wire::Deform{++seq, s.stamp(StampKind::kFlatten, 500, 500, 30)});  // over the cap
  s.send(b, wire::Deform{1, s.stamp(StampKind::kGaussian, 100, 100, 10)});     // a viewer
  s.tick(tick, 6.0);
  {
    QuantizedStamp off = s.stamp(StampKind::kGaussian, 100, 100, 10);
    off.center_x = int64_t(1) << 40;
    s.send(a, wire::Deform{++seq, off});
  }
  s.send(a, wire::Deform{++seq, s.stamp(StampKind::kFlatten, 500, 500, 30)});
  s.send(a, wire::Deform{++seq, s.stamp(StampKind::kShockwave, 512, 300, 12)});
  s.send(a, wire::Deform{++seq, s.stamp(StampKind::kGaussian, 300, 300, 8, Layer::kDetail)});
  s.send(a, wire::Deform{++seq, s.stamp(StampKind::kCrater, 700, 400, 15)});  // out of tokens
  for (int i = 0; i < 4; ++i) s.tick(tick, 40.0 + i);                         // overruns

  s.step("requests: ping, stats, images, a flood, a server-to-client type, a second Hello");
  s.send(a, wire::Ping{123456});
  s.send(b, wire::StatsRequest{9});
  s.send(b, wire::StampImageRequest{s.texture_id()});
  s.send(b, wire::StampImageRequest{1});
  s.send(b, wire::StampImageListRequest{3});
  for (uint64_t i = 0; i < 8; ++i) s.send(b, wire::Ping{i});
  {
    const auto until = s.core().reads_paused_until(b, s.now());
    s.lines().push_back("reads_paused_until c" + std::to_string(b) + " " +
                        (until ? std::to_string((*until - s.now()).count()) : std::string("none")));
  }
  s.send(a, wire::Welcome{});
  s.send(a, wire::Hello{});
  s.send(a, wire::ErrorMsg{wire::WireErrorCode::kInternal, "x", "client says"});

  s.step("streaming under the budget; bob not reading for a while");
  s.set_unsent(b, 1u << 20);
  s.tick(tick, 3.0);
  s.set_unsent(b, 0);
  for (int i = 0; i < 6; ++i) s.tick(250ms, 3.0 + i * 0.5);
  s.report_stats(4096);

  s.step("reconnect: alice's link drops with a Deform waiting; she resends on a new connection");
  s.send(a, wire::Deform{++seq, s.stamp(StampKind::kCrater, 700, 400, 15)});
  const uint32_t waiting = seq;
  s.disconnected(a, "link lost");
  const ClientId alice2 = s.join("alice", "10.0.0.1:1001", kEditorToken, 42);
  s.send(alice2, wire::Deform{waiting - 1, s.stamp(StampKind::kShockwave, 512, 300, 12)});  // answered before
  s.send(alice2, wire::Deform{waiting, s.stamp(StampKind::kCrater, 700, 400, 15)});         // still waiting
  s.tick(tick, 5.0);
  {
    // Back on the tiles she held, at version 0: the changed ones come as patches or deltas.
    wire::Subscribe sub = s.subscribe_all(true);
    sub.focus = wire::Focus{100, 100};
    s.send(alice2, sub);
  }
  for (int i = 0; i < 4; ++i) s.tick(200ms, 4.0);
  s.send(alice2, wire::Unsubscribe{{TileCoord{Layer::kCoarse, 0, 0, 0}, TileCoord{Layer::kCoarse, 0, 1, 0}}});

  s.step("a late joiner gets the whole tiles others already fetched (the cache, the best mode)");
  const ClientId h = s.join("heidi", "10.0.0.9:1", kEditorToken, 0, wire::Role::kPlayer);
  s.send(h, s.subscribe_all(false));
  for (int i = 0; i < 6; ++i) s.tick(300ms, 4.0);
  s.send(h, wire::Deform{1, s.stamp(StampKind::kGaussian, 128, 128, 40)});
  s.send(alice2, wire::Deform{++seq, s.stamp(StampKind::kFootprint, 130, 140, 6)});
  s.tick(tick, 4.0);
  for (int i = 0; i < 12; ++i) s.tick(1s, 4.0);  // snapshots by count and by interval
  s.send(h, wire::StatsRequest{10});
  s.report_stats(0);

  s.step("faults: a bad stream, an idle timeout, a token reload");
  s.stream_error(b);
  s.timed_out(h, false);
  s.core().reload_tokens();
  s.collect();
  s.tick(tick, 4.0);

  s.step("metrics");
  {
    std::istringstream text(s.metrics_text(777));
    for (std::string line; std::getline(text, line);) s.lines().push_back("  " + line);
  }

  s.step("shutdown");
  s.core().shutdown("script over", s.now() + 1s, 1'700'000'001'000'000);
  s.collect();

  s.step("log records");
  for (const std::string& path : list_segments(s.data_dir())) {
    auto scan = log::read_segment(path);
    EXPECT_TRUE(scan.ok());
    if (!scan.ok()) continue;
    s.lines().push_back("segment " + std::to_string(scan->header.header.segment_index) + " base_seq " +
                        std::to_string(scan->header.header.base_seq) + " base_tick " +
                        std::to_string(scan->header.header.base_tick));
    for (const log::LogRecord& r : scan->records) {
      const QuantizedStamp& q = r.stamp;
      s.lines().push_back("  seq " + std::to_string(r.global_seq) + " tick " + std::to_string(r.tick) +
                          " client " + std::to_string(r.client_id) + " " + to_string(q.kind) + " layer " +
                          std::to_string(int(q.layer)) + " at " + std::to_string(q.center_x) + "," +
                          std::to_string(q.center_y) + " r " + std::to_string(q.radius));
    }
  }

  s.step("core log lines (rate-limited kinds left out)");
  std::istringstream err(testing::internal::GetCapturedStderr());
  for (std::string line; std::getline(err, line);) {
    const std::string n = normalized_log_line(line, s.data_dir());
    if (!n.empty()) s.lines().push_back("  " + n);
  }
  return s.lines();
}

std::string join_lines(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& l : lines) out += l + "\n";
  return out;
}

// The whole script twice in one process gives the same transcript (no hidden state, no clock),
// and that transcript is the committed one.
TEST(CoreTranscript, AScriptedSessionSendsExactlyTheCommittedFramesLogAndCounters) {
  const std::string got = join_lines(run_script());
  ASSERT_GT(got.size(), 1000u);
  if (std::getenv("LOAM_REGENERATE_GOLDEN") != nullptr) {
    std::filesystem::create_directories(std::filesystem::path(kGoldenPath).parent_path());
    std::ofstream(kGoldenPath, std::ios::binary) << got;
    GTEST_SKIP() << "regenerated " << kGoldenPath;
  }
  EXPECT_EQ(join_lines(run_script()), got) << "the script is not deterministic";
  std::ifstream f(kGoldenPath, std::ios::binary);
  ASSERT_TRUE(f) << "missing " << kGoldenPath << " (LOAM_REGENERATE_GOLDEN=1 writes it)";
  const std::string want((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (got == want) return;
  // Name the first line that moved, then the whole diff is a `diff` away.
  std::istringstream g(got), w(want);
  std::string gl, wl;
  for (size_t n = 1;; ++n) {
    const bool more_g = bool(std::getline(g, gl)), more_w = bool(std::getline(w, wl));
    if (!more_g && !more_w) break;
    if (!more_g || !more_w || gl != wl) {
      ADD_FAILURE() << "line " << n << " moved:\n  golden: " << (more_w ? wl : "<end>")
                    << "\n  now:    " << (more_g ? gl : "<end>");
      break;
    }
  }
}

}  // namespace
}  // namespace loam::server
