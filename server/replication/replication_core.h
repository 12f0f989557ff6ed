// The replication core: everything the server decides, with no sockets and no clock of its
// own. A transport (server/server.h, Asio) hands it decoded messages and the time, and takes
// back the frames to write to each client and the clients to close. Tests drive it directly
// with a made-up clock (tests/server/replication_core_test.cpp).
//
// It owns:
//  - admission: the handshake, access tokens and roles, the client cap, per-client rate
//    limits (token bucket) and the per-client cap on unacknowledged deforms;
//  - the per-tick commit pipeline: sequence the tick's stamps, log them with one sync (the
//    durability point), acknowledge (an ack means durable and sequenced; the transport sends
//    acks at once), apply on the apply worker in sequence order (server/apply_worker.h), and
//    once applied fan out DeformEvents (one encoding for all). The transport waits a few
//    milliseconds for the apply; past that, what needs the applied world (events, regions,
//    hashes, snapshots) waits for a later tick while acks, pings and handshakes go on;
//  - replication planning per client and tile (server/replication/client_tiles.h): the event
//    alone, or a region due (patch or whole tile);
//  - bulk streaming: due regions leave under each client's byte budget, coarsest mip first and
//    then nearest the client's focus, at the tile's newest version, encoded once for every
//    client needing the same bytes (region_frames.h), with a bound on encodes per tick so a
//    join storm cannot stall the tick; acks, events, pongs and errors go at once, outside it;
//    patches for a client behind are deltas against what it holds (tile_history.h), and
//    tiles sent to many are re-encoded in the best mode on a worker thread;
//  - TileHashes, snapshots, storage back-off after a failed sync, and stats.
//
// It composes four units, each with its own state and tests: Admission (admission.h: the
// pools, tokens and per-client allowances), CommitPipeline (commit_pipeline.h: queue, sequence,
// log, sync, apply, the ledger), RegionStreamer (region_streamer.h: bulk under the budgets) with
// TileHashRound (tile_hash_round.h), and SnapshotSchedule with StorageRetry
// (snapshot_schedule.h). The core's own files glue them to the clients and the output:
// core_admission.cpp, core_commit.cpp, core_streaming.cpp, core_snapshots.cpp,
// core_reporting.cpp, and replication_core.cpp (the clients, the output, the dispatch of
// messages and shutdown).
//
// Time is given, never read (core_time.h): every call that needs the time takes it, the
// transport owns every wait (the tick's wait for its apply included: the core only says what it
// waits for, applying()), and it times the tick's phases (run_tick).
//
// Call it from one thread (the transport's I/O thread); stamps are applied, and best-mode
// re-encodes run, on workers of their own.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "protocol/wire/messages.h"
#include "server/access_tokens.h"
#include "server/apply_worker.h"
#include "server/counters.h"
#include "server/event_log.h"
#include "server/metrics.h"
#include "server/replication/admission.h"
#include "server/replication/client_tiles.h"
#include "server/replication/commit_pipeline.h"
#include "server/replication/core_time.h"
#include "server/replication/region_frames.h"
#include "server/replication/region_streamer.h"
#include "server/replication/snapshot_schedule.h"
#include "server/replication/tile_history.h"
#include "server/replication/token_bucket.h"
#include "server/server_config.h"
#include "server/storage.h"
#include "server/tile_prefetcher.h"

namespace loam::server {

using ClientId = uint32_t;

// A line for the server's log (event_log.h). The transport writes it: a line's time and its
// rate limit are the writer's clock, and the core reads none.
struct CoreLogLine {
  const char* event = "";
  std::vector<Field> fields;
};

// What the transport must do after a call into the core.
struct CoreOutput {
  std::vector<std::pair<ClientId, FramePtr>> frames;     // write, in this order per client
  std::vector<std::pair<ClientId, std::string>> closes;  // stop reading; close once flushed
  std::vector<CoreLogLine> log;                          // write to the log, in this order
};

class ReplicationCore {
 public:
  // `transport`: the counters the transport keeps (bytes, TLS failures, its largest queue),
  // read when reporting; null: none.
  ReplicationCore(ServerConfig config, OpenedStorage storage, CoreTime now,
                  const TransportCounters* transport = nullptr);

  // A new connection. The client must say Hello before the handshake timeout (the transport's
  // timer calls timed_out).
  ClientId connect(const std::string& peer, CoreTime now);
  // `wall`: the wall clock's time, for Pong.
  void receive(ClientId id, const wire::Message& m, CoreTime now, UnixMicros wall);
  // The transport could not decode the client's stream: Error, Bye, close.
  void stream_error(ClientId id, const Error& e);
  // A handshake or idle timer fired.
  void timed_out(ClientId id, bool in_handshake);
  // The connection is gone (closed by either side, or dropped by the transport).
  void disconnected(ClientId id, const std::string& reason);
  bool in_handshake(ClientId id) const;
  // When a client that has had a request refused for its rate may be read again (its request
  // bucket holds a token by then); nullopt when it may be read now. The transport stops
  // decoding its frames until then, so a flood costs the flooder, not this thread.
  std::optional<CoreTime> reads_paused_until(ClientId id, CoreTime now) const;

  // One tick, in phases the transport calls in this order, all at the tick's time `now`
  // (run_tick below is that order):
  // 1. Counts the tick, retries the storage after a failed sync, and sequences and logs the
  //    tick's stamps (up to its cost budget). False when stopping or failed: no tick.
  bool begin_tick(CoreTime now);
  // 2. One sync (the durability point), then the stamps' acks in the output, and their apply
  //    queued. True when acks of a committed batch are ready: the transport sends them then, so
  //    no client's ack waits for another's heavy stamp, nor for the tick's streaming.
  bool commit(CoreTime now);
  // 3. Publishes what the apply worker finished (events, history, plans) and starts what is
  //    sequenced. True once the world is free; while false, the tick waits on applying() (up to
  //    the transport's apply wait) and calls this again, or goes on without the apply.
  bool advance_apply();
  ApplyWorker* applying() { return commits_.applying(); }
  // 4. With the world free: deferred subscriptions, best-mode encodes adopted, regions under
  //    each client's budget, TileHashes. `unsent(id)`: bytes queued for the client and not yet
  //    written (bulk waits while it is over the client's one-second budget: a client that does
  //    not read gets no more regions, only what must go).
  void stream(CoreTime now, const std::function<uint64_t(ClientId)>& unsent);
  // 5. A snapshot due (its new log segment records `wall`), or adopted once written.
  void persist(CoreTime now, UnixMicros wall);
  // 6. Clean base tiles read this tick back under the cache budget.
  void trim();
  // Where the transport measured the tick's time to go (stats; overruns are logged with it).
  struct TickTimes {
    double total_ms = 0, sync_ms = 0, commit_ms = 0, apply_wait_ms = 0, stream_ms = 0, snapshot_ms = 0,
           trim_ms = 0;
    bool world_busy = false;  // the apply outlasted the tick's wait: no streaming this tick
  };
  void record_tick(const TickTimes& times);
  // Graceful stop: make the log durable, write a snapshot, Bye to every client.
  void shutdown(const std::string& reason, CoreTime now, UnixMicros wall);
  bool stopping() const { return stopping_; }
  void reload_tokens();
  void warn_if_tokens_file_exposed();
  // The periodic stats line (the transport's timer).
  void report_stats(CoreTime now);

  CoreOutput take_output() { return std::exchange(out_, {}); }
  // The log lines alone (a transport writing them where it sends nothing).
  std::vector<CoreLogLine> take_log() { return std::exchange(out_.log, {}); }
  const ServerStats& stats() const { return stats_; }
  const RegionFrameCounters& region_counters() const { return streamer_.frames().counters(); }
  const TileHistory& tile_history() const { return history_; }
  // Every number the server reports (counters.h), now: /metrics, the stats line and Stats.
  MetricsSnapshot metrics() const;
  // Waits for the best-mode re-encodes running off the tick thread and adopts them (tests).
  void finish_background_encodes() { streamer_.frames().finish_best(); }
  bool failed() const { return failed_; }
  uint64_t tick_count() const { return tick_; }
  // The terrain; its world only while no apply runs (after tick(), or finish_applying()).
  const TerrainState& terrain() const { return terrain_; }
  // Waits for the apply in flight and applies everything sequenced (tests, shutdown).
  void finish_applying();
  // The last sequence logged and acknowledged, and the last applied with its events sent.
  uint64_t sequenced_seq() const { return commits_.sequenced_seq(); }
  uint64_t published_seq() const { return commits_.published_seq(); }
  const AccessTokens& access() const { return admission_.access(); }
  const ServerConfig& config() const { return config_; }
  size_t clients() const { return clients_.size(); }
  // The core's view of a client's tiles (tests).
  const ClientTiles* tiles_of(ClientId id) const;
  // The base's worker that makes tiles ahead (null when off or the base is uniform).
  const PrefetchingBase* prefetcher() const { return prefetch_.get(); }

 private:
  struct Client {
    enum class State { kHandshake, kReady };
    ClientId id = 0;
    State state = State::kHandshake;
    std::string name, peer;
    std::string address;      // the peer without its port: the per-address handshake limit
    uint64_t resume_key = 0;  // Hello's: resent Deforms are recognised by it (deform_ledger.h)
    wire::Role role = wire::Role::kPlayer;
    bool editor = true;
    uint64_t violations = 0;
    ClientAllowance allowance;  // what it may still ask (admission.h)
    ClientTiles tiles;
    TokenBucket credit;  // bulk bytes (region_streamer.h)
  };
  // A line for the log, handed to the transport with the output.
  void note(const char* event, std::initializer_list<Field> fields) { out_.log.push_back({event, fields}); }
  void note(const char* event, std::vector<Field> fields) { out_.log.push_back({event, std::move(fields)}); }
  void send(Client& c, const wire::Message& m);
  void send_frame(ClientId id, FramePtr frame);
  void violation(Client& c, wire::WireErrorCode code, const std::string& field, const std::string& text);
  void fatal(Client& c, wire::WireErrorCode code, const std::string& field, const std::string& text,
             wire::ByeReason reason);
  void close(ClientId id, const std::string& reason);
  // Removes a client and its share of the handshake or session counts; false if unknown.
  bool erase_client(ClientId id);

  // Takes a request token; false (the request is dropped) when the client is over its rate.
  bool admit_request(Client& c, wire::MessageType type, CoreTime now);
  void refuse_deform(Client& c, uint32_t client_seq, const Refusal& r);
  void on_hello(Client& c, const wire::Hello& h);
  void on_subscribe(Client& c, const wire::Subscribe& sub);
  void on_deform(Client& c, const wire::Deform& d, CoreTime now);
  void on_stamp_image(Client& c, const wire::StampImageRequest& r);
  void on_stamp_image_list(Client& c, const wire::StampImageListRequest& r);
  wire::Stats stats_message(uint32_t request_id, CoreTime now) const;
  bool valid_tile(const TileCoord& t) const;

  // Refuses a batch the storage cannot take: nothing of it is logged or applied.
  void refuse(const std::vector<PendingDeform>& batch);
  void publish(std::vector<ApplyWorker::Output> applied);
  CommitPipeline::Publish publisher() {
    return [this](std::vector<ApplyWorker::Output> applied) { publish(std::move(applied)); };
  }
  // Subscribe and Unsubscribe read the world's tile versions: while an apply runs they wait
  // here, in order, for the world to be free.
  void receive_subscription(Client& c, const wire::Message& m);
  void run_deferred_subscriptions();
  void refresh_world_counters();
  void acknowledge(const PendingDeform& p, std::optional<uint64_t> seq);
  void stream_regions(CoreTime now, const std::function<uint64_t(ClientId)>& unsent);
  void send_hashes();
  // Logs a snapshot's outcome; a failure backs off the next try.
  void snapshot_done(const Result<SnapshotOutcome>& done, CoreTime now);
  // Queues the base tiles an admitted stamp will read, at every mip under its reach.
  void prefetch_reach(const QuantizedStamp& q);
  void maybe_snapshot(CoreTime now, UnixMicros wall, bool force);
  void try_resume_storage(CoreTime now);

  ServerConfig config_;
  Storage storage_;
  TerrainState terrain_;
  Admission admission_;
  CommitPipeline commits_;
  RegionStreamer streamer_;
  SnapshotSchedule snapshots_;
  StorageRetry storage_retry_;
  TileHistory history_;
  std::shared_ptr<PrefetchingBase> prefetch_;
  std::map<ClientId, Client> clients_;
  std::vector<std::pair<ClientId, wire::Message>> deferred_subscriptions_;
  // The world's counters as of the last time it was free (stats and metrics read these, never
  // the world while an apply runs).
  struct WorldCounters {
    uint64_t edited_bytes = 0, base_cache_bytes = 0, base_tiles_generated = 0, unpersisted_bytes = 0,
             edited_tiles_loaded = 0;
  };
  WorldCounters world_counters_;
  ClientId next_id_ = 1;
  uint64_t tick_ = 0;
  bool stopping_ = false;
  bool failed_ = false;
  CoreOutput out_;
  ServerStats stats_;
  TransportCounters no_transport_;
  const TransportCounters* transport_;
  CoreTime started_;
  size_t last_batch_ = 0;  // stamps in the last tick
  // The world's counters when the tick began, and the tiles the last tick had to read from the
  // base or reload from the snapshot store (logged with an overrun).
  WorldCounters tick_start_counters_;
  uint64_t tick_base_tiles_read_ = 0, tick_edited_tiles_loaded_ = 0;
  std::vector<double> tick_ms_;  // since the last stats line
  TickHistogram ticks_;          // every tick since start, for /metrics
  double last_p50_ms_ = 0, last_p99_ms_ = 0;
};

// The phases of one tick in order, for the transport and for tests. The caller owns the clock:
// `wait_for_apply(worker)` is its wait on the apply in flight (true once it has finished, false
// to go on without it), and `phase_done(phase)` is called as each phase ends (to time them).
enum class TickPhase { kLogged, kSynced, kCommitted, kApplied, kStreamed, kPersisted, kTrimmed };
struct TickHooks {
  std::function<uint64_t(ClientId)> unsent;  // bytes queued for a client (none: 0)
  std::function<void()> acks_ready;          // the tick's acks are in the output
  std::function<bool(ApplyWorker&)> wait_for_apply;
  std::function<void(TickPhase)> phase_done;
};
// False when the apply outlasted the wait: the tick did not stream (nor persist, nor trim).
bool run_tick(ReplicationCore& core, CoreTime now, UnixMicros wall, const TickHooks& hooks);

}  // namespace loam::server
