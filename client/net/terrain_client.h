// TerrainClient: a connection plus the confirmed store — what tests, bots and the viewer
// use. pump() handles incoming messages in order: Welcome state, regions (reassembled from
// chunks, decoded with the region codec and checked), events (applied or buffered by the
// store), acks (remembered by the client's own sequence), hashes (a tile held at the hashed
// version with another hash is re-requested whole; one still behind the hashed version a round
// later is re-requested from the version held: docs/protocol.md, "TileHashes"), Bye/Error
// (recorded). Waiting is always for a condition with a timeout, never a sleep.
#pragma once

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "client/net/confirmed_store.h"
#include "client/net/connection.h"
#include "client/net/deform_pacer.h"
#include "protocol/base/tile_base.h"

namespace loam::client {

struct AckResult {
  bool accepted = false;
  uint64_t global_seq = 0;
  wire::WireErrorCode code = wire::WireErrorCode::kInternal;
  std::string field;
  // No answer will come: the connection was lost after the Deform left, and the server the
  // client reconnected to did not know its resume key (a restart). The server may or may not
  // have applied it; the confirmed tiles show which. Not accepted, not rejected.
  bool lost = false;
};

// Returns the base of `identity` (TileBase::identity) when this program can generate it, else
// null. The client asks it once per connection for Welcome's base_identity.
using BaseProvider = std::function<std::shared_ptr<const TileBase>(uint64_t identity)>;

class TerrainClient {
 public:
  TerrainClient() = default;

  // Bases this client can generate (call before connect). Without one, or when the server's
  // base is unknown to it, every tile is downloaded as before.
  void set_base_provider(BaseProvider provider) { base_provider_ = std::move(provider); }
  // TLS for every connection from here on, reconnects included (call before connect).
  void set_tls(transport::TlsClientOptions options) { tls_ = std::move(options); }
  // The base the client generates untouched tiles from (null: none), and how many it made.
  const TileBase* base() const { return base_.get(); }
  // The same, shared (it is replaced on a reconnect): every tile's version 0, the session's
  // initial terrain.
  const std::shared_ptr<const TileBase>& shared_base() const { return base_; }
  uint64_t tiles_generated() const { return tiles_generated_; }
  // RegionUpdate messages received (chunks of whole tiles or patches) since connect.
  uint64_t region_chunks_received() const { return region_chunks_received_; }

  Status connect(const std::string& host, uint16_t port, const std::string& name,
                 wire::Role role = wire::Role::kPlayer, std::optional<wire::AccessToken> token = {});
  // Reconnects after a lost connection and resumes: the store is kept, and every tile is
  // subscribed again with the version held, so the server sends only tiles that changed;
  // Deforms sent and not answered go again under the same resume key (applied once).
  Status reconnect(const std::string& host, uint16_t port);
  const wire::Welcome& welcome() const { return welcome_; }
  Connection& connection() { return *connection_; }

  // Subscribes to tiles (held versions from the store, so a reconnect resumes). `focus`, the
  // camera's ground position in world meters, orders what the server sends first (coarsest
  // mip, then nearest); with no tiles it only moves the focus.
  Status subscribe(const std::vector<TileCoord>& tiles, std::optional<wire::Focus> focus = {});
  // Drops tiles: the server stops sending them and the store forgets them.
  Status unsubscribe(const std::vector<TileCoord>& tiles);
  // Every mip-0 coarse tile of the world.
  std::vector<TileCoord> all_coarse_tiles(int32_t mip = 0) const;
  // Sends a Deform; returns the client's own sequence number for it. Within the limits the
  // Welcome announced (unacknowledged Deforms, Deforms a second) it leaves at once; beyond them,
  // or while the connection is down, it waits here, in order, and pump() (or reconnect()) sends
  // it when an ack, time or a new connection allows (deform_pacer.h).
  Result<uint32_t> deform(const QuantizedStamp& stamp);
  // Deforms waiting to be sent, and sent but not yet acknowledged.
  size_t deforms_queued() const { return pacer_.queued(); }
  size_t deforms_unacked() const { return pacer_.unacked(); }

  // Handles messages for up to `timeout`: returns when the inbox has stayed empty that long, or
  // once the timeout has passed with messages still coming (at least one is handled).
  // An Error result means the connection is gone.
  Status pump(std::chrono::milliseconds timeout);
  // Pumps until pred() holds; false on timeout or a closed connection.
  bool wait_until(const std::function<bool()>& pred, std::chrono::milliseconds timeout);
  std::optional<AckResult> ack(uint32_t client_seq) const;

  // The session's numbers, for a HUD: ping() sends a Ping, whose Pong gives the round trip as
  // this client sees it (until pump() handles the Pong, so a viewer's frame time is in it);
  // request_stats() sends a StatsRequest, whose Stats (the server's tick times, clients,
  // bytes) is kept. Both are answered in pump().
  Status ping();
  Status request_stats();
  std::optional<double> rtt_ms() const { return rtt_ms_; }
  const std::optional<wire::Stats>& server_stats() const { return server_stats_; }

  // Stamp images fetched from the server (StampImageRequest) as texture-stamp events need them,
  // or as the list below names them.
  const TextureRegistry& textures() const { return textures_; }
  // The server's registered stamp images, for a tool panel: request_stamp_images() asks for
  // the list (answered in pump()) and fetches every image the server serves, so it can be previewed and
  // stamps with it predicted.
  Status request_stamp_images();
  const std::vector<wire::StampImageListEntry>& stamp_images() const { return stamp_images_; }
  ConfirmedStore& store() { return *store_; }
  const ConfirmedStore& store() const { return *store_; }
  uint64_t last_seen_seq() const { return last_seen_seq_; }
  // The newest DeformEvent received (events arrive in global order): an accepted stamp of
  // ours with a global sequence at or below it has had its event delivered, if one was due.
  uint64_t last_event_seq() const { return last_event_seq_; }
  const std::vector<wire::ErrorMsg>& errors() const { return errors_; }
  std::optional<wire::Bye> bye() const { return bye_; }
  uint64_t hash_mismatches() const { return store_ ? store_->counters().hash_mismatches : 0; }
  size_t tile_hash_messages() const { return tile_hash_messages_; }
  // Messages this client could not use (failed decode or checks), oldest first.
  const std::vector<Error>& local_errors() const { return local_errors_; }

 private:
  Status handle(wire::Message& m);
  Status on_region_chunk(const wire::RegionUpdate& r);
  Status on_stamp_image(const wire::StampImageResponse& r);
  Status request_missing_textures();

  Status handshake(const std::string& host, uint16_t port);
  Status send_paced();

  std::unique_ptr<Connection> connection_ = std::make_unique<Connection>();
  std::string name_;
  wire::Role role_ = wire::Role::kPlayer;
  std::optional<wire::AccessToken> token_;
  uint64_t resume_key_ = 0;  // random, kept across reconnects: resent Deforms count once
  wire::Welcome welcome_;
  std::unique_ptr<ConfirmedStore> store_;
  std::map<TileCoord, wire::RegionAssembler> assemblers_;
  TextureRegistry textures_;
  std::set<uint64_t> textures_requested_;
  std::vector<wire::StampImageListEntry> stamp_images_;
  uint32_t image_list_request_id_ = 0;
  std::map<uint32_t, AckResult> acks_;
  DeformPacer pacer_;
  std::vector<wire::ErrorMsg> errors_;
  std::vector<Error> local_errors_;
  std::optional<wire::Bye> bye_;
  uint32_t next_client_seq_ = 1;
  uint64_t last_seen_seq_ = 0;
  uint64_t last_event_seq_ = 0;
  size_t tile_hash_messages_ = 0;
  // Tiles a TileHashes round found behind the server's version, with the version held then.
  std::map<TileCoord, uint64_t> behind_;
  BaseProvider base_provider_;
  transport::TlsClientOptions tls_;
  std::shared_ptr<const TileBase> base_;
  uint64_t tiles_generated_ = 0;
  uint64_t region_chunks_received_ = 0;
  std::optional<double> rtt_ms_;
  std::optional<wire::Stats> server_stats_;
  uint32_t stats_request_id_ = 0;
};

}  // namespace loam::client
