// The replication core: everything the server decides, with no sockets and no clock of its
// own. A transport (server/server.h, Asio) hands it decoded messages and the time, and takes
// back the frames to write to each client and the clients to close. Tests drive it directly
// with a made-up clock (tests/server/replication_core_test.cpp).
//
// It owns:
//  - admission: the handshake, access tokens and roles, the client cap, per-client rate
//    limits (token bucket) and the per-client cap on unacknowledged deforms;
//  - the per-tick commit pipeline: sequence the tick's stamps, log them with one sync (the
//    durability point), apply, acknowledge, fan out DeformEvents (one encoding for all);
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
// Call it from one thread (the transport's I/O thread); only the best-mode re-encodes run on
// a worker of their own.
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
#include "server/metrics.h"
#include "server/replication/client_tiles.h"
#include "server/replication/deform_ledger.h"
#include "server/replication/region_frames.h"
#include "server/replication/tile_history.h"
#include "server/server_config.h"
#include "server/storage.h"
#include "server/tile_prefetcher.h"

namespace loam::server {

using ClientId = uint32_t;
using CoreClock = std::chrono::steady_clock;
using CoreTime = CoreClock::time_point;

struct ServerStats {
  uint64_t connects = 0, disconnects = 0;
  uint64_t deforms_accepted = 0, deforms_rejected = 0;
  uint64_t violations = 0;        // every Error sent for a client's fault
  uint64_t requests_refused = 0;  // requests over a client's rate, dropped
  uint64_t deforms_resent = 0;    // Deforms seen again after a reconnect: answered, not applied
  std::map<std::string, uint64_t> deforms_rejected_by;  // by reason (wire error code name)
  uint64_t bytes_in = 0, bytes_out = 0;
  uint64_t regions_sent = 0, partial_regions_sent = 0, events_sent = 0;
  uint64_t tick_overruns = 0;
  uint64_t storage_failures = 0;  // syncs that failed (a full disk): edits refused until resumed
  uint64_t snapshots = 0, snapshot_bytes_written = 0;
};

// What the transport must do after a call into the core.
struct CoreOutput {
  std::vector<std::pair<ClientId, FramePtr>> frames;     // write, in this order per client
  std::vector<std::pair<ClientId, std::string>> closes;  // stop reading; close once flushed
};

class ReplicationCore {
 public:
  ReplicationCore(ServerConfig config, OpenedStorage storage, CoreTime now);

  // A new connection. The client must say Hello before the handshake timeout (the transport's
  // timer calls timed_out).
  ClientId connect(const std::string& peer, CoreTime now);
  void receive(ClientId id, const wire::Message& m, CoreTime now);
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

  // One tick at `now`. `unsent(id)`: bytes queued for the client and not yet written (bulk
  // waits while it is over the client's one-second budget: a client that does not read gets
  // no more regions, only what must go).
  void tick(CoreTime now, const std::function<uint64_t(ClientId)>& unsent);
  // Graceful stop: make the log durable, write a snapshot, Bye to every client.
  void shutdown(const std::string& reason, CoreTime now);
  bool stopping() const { return stopping_; }
  // How long the transport measured the last tick to take (stats; overruns are logged).
  void record_tick_ms(double ms);
  void reload_tokens();
  void warn_if_tokens_file_exposed();
  // The periodic stats line (the transport's timer).
  void report_stats(CoreTime now, uint64_t max_queue_bytes);

  CoreOutput take_output() { return std::exchange(out_, {}); }
  const ServerStats& stats() const { return stats_; }
  ServerStats& mutable_stats() { return stats_; }  // the transport counts bytes in and out
  const RegionFrameCounters& region_counters() const { return frames_.counters(); }
  const TileHistory& tile_history() const { return history_; }
  // Everything /metrics reports (metrics.h); the transport adds its largest send queue.
  MetricsSnapshot metrics(uint64_t max_queue_bytes) const;
  // Waits for the best-mode re-encodes running off the tick thread and adopts them (tests).
  void finish_background_encodes() { frames_.finish_best(); }
  bool failed() const { return failed_; }
  uint64_t tick_count() const { return tick_; }
  const TerrainState& terrain() const { return terrain_; }
  const AccessTokens& access() const { return access_; }
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
    double tokens = 0;  // deform token bucket
    CoreTime refill;
    double cost_tokens = 0;  // stamp cost bucket (sample updates)
    uint32_t unacked = 0;    // deforms accepted into the queue, not yet acknowledged
    uint64_t violations = 0;
    double requests = 0;  // request token bucket (Subscribe, Unsubscribe, Ping, ...)
    CoreTime requests_refill;
    bool requests_refused = false;  // refused since the last one accepted: Error already sent
    ClientTiles tiles;
    double credit = 0;  // bulk byte budget
    CoreTime credit_time;
  };
  struct PendingDeform {
    ClientId client = 0;
    uint32_t client_seq = 0;
    QuantizedStamp stamp;
    uint64_t cost = 0;  // stamp_cost
    uint64_t key = 0;   // the sender's resume key (0: none)
  };

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
  void on_hello(Client& c, const wire::Hello& h);
  void on_subscribe(Client& c, const wire::Subscribe& sub);
  void on_deform(Client& c, const wire::Deform& d, CoreTime now);
  void on_stamp_image(Client& c, const wire::StampImageRequest& r);
  wire::Stats stats_message(uint32_t request_id, CoreTime now) const;
  bool valid_tile(const TileCoord& t) const;

  void commit_batch(std::vector<PendingDeform> batch, CoreTime now);
  void acknowledge(const PendingDeform& p, std::optional<uint64_t> seq);
  void stream_regions(CoreTime now, const std::function<uint64_t(ClientId)>& unsent);
  // Untouched tiles it must read to hash come out of base_reads_left; past it they go to later.
  void send_hashes(Client& c, uint32_t& base_reads_left, std::vector<TileCoord>& later);
  // Logs a snapshot's outcome; a failure backs off the next try.
  void snapshot_done(const Result<SnapshotOutcome>& done, CoreTime now);
  // Queues the base tiles an admitted stamp will read, at every mip under its reach.
  void prefetch_reach(const QuantizedStamp& q);
  void maybe_snapshot(CoreTime now, bool force);
  void try_resume_storage(CoreTime now);

  ServerConfig config_;
  AccessTokens access_;
  Storage storage_;
  TerrainState terrain_;
  RegionFrames frames_;
  TileHistory history_;
  std::shared_ptr<PrefetchingBase> prefetch_;
  CoreTime snapshot_started_{};
  std::map<ClientId, Client> clients_;
  // Connections still in their handshake (all, and per address) and clients in session: the
  // pools --max-handshakes, --max-handshakes-per-address and --max-clients bound.
  size_t handshakes_ = 0, sessions_ = 0;
  DeformLedger ledger_{4096, 1024};
  std::map<uint64_t, ClientId> key_owner_;  // resume key -> its newest connection
  std::map<std::string, uint32_t> handshakes_by_address_;
  std::vector<PendingDeform> pending_;
  ClientId next_id_ = 1;
  uint64_t tick_ = 0;
  bool stopping_ = false;
  bool failed_ = false;
  CoreOutput out_;
  ServerStats stats_;
  CoreTime started_;
  CoreTime last_snapshot_time_;
  // A failed snapshot is retried after a growing interval (a full disk).
  static constexpr double kSnapshotBackoffMinS = 5.0, kSnapshotBackoffMaxS = 300.0;
  double snapshot_backoff_s_ = 0;
  CoreTime snapshot_retry_after_{};
  // A failed log sync refuses edits; reopening is retried after a growing interval.
  static constexpr double kResumeBackoffMinS = 0.25, kResumeBackoffMaxS = 10.0;
  double resume_backoff_s_ = kResumeBackoffMinS;
  CoreTime next_resume_try_{};
  size_t stream_cursor_ = 0;  // bulk turns rotate so no client always goes first
  size_t last_batch_ = 0;     // stamps in the last tick
  double sync_ms_ = 0;        // the last tick's log sync
  // Where the last tick's time went (logged when it overran its period): committing (the log
  // sync within it), streaming regions and hashes, the snapshot's start or adoption, the trim;
  // and the tiles it had to read from the base or reload from the snapshot store.
  struct TickPhases {
    double sync_ms = 0, commit_ms = 0, stream_ms = 0, snapshot_ms = 0, trim_ms = 0;
    uint64_t base_tiles_read = 0, edited_tiles_loaded = 0;
  };
  TickPhases last_phases_;
  std::vector<double> tick_ms_;  // since the last stats line
  TickHistogram ticks_;          // every tick since start, for /metrics
  double last_p50_ms_ = 0, last_p99_ms_ = 0;
};

}  // namespace loam::server
