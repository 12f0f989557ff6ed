#include "client/net/terrain_client.h"

#include <algorithm>
#include <random>

#include "protocol/byte_order.h"
#include "protocol/codec/region_codec.h"

namespace loam::client {

namespace {
// Microseconds of the steady clock (never 0 in practice): what a Ping carries and its Pong echoes.
uint64_t steady_us() {
  return uint64_t(std::chrono::duration_cast<std::chrono::microseconds>(
                      std::chrono::steady_clock::now().time_since_epoch())
                      .count());
}
}  // namespace

Status TerrainClient::handshake(const std::string& host, uint16_t port) {
  wire::Hello hello;
  hello.client_name = name_;
  hello.requested_role = role_;
  hello.access_token = token_;
  hello.resume_key = resume_key_;
  // A reconnect must find the session it left: the same world, and a sequence at least the one
  // this client saw (what the server acknowledged or announced is durable). Anything else is
  // another server, or a session restored from an older backup: nothing in flight goes there.
  // Welcome names the last stamp applied, and an ack goes out at the durability point, before
  // the apply: a server that still holds this client's resume key is the same live session
  // (its ledger does not survive a restart), whose acknowledged stamps are applied and
  // announced after the Welcome, so there only the events received must be reached.
  const bool resuming = store_ != nullptr;
  const WorldParams before = welcome_.world;
  connection_->set_tls(tls_);
  auto w = connection_->connect(host, port, hello);
  if (!w) return w.error();
  welcome_ = *w;
  if (resuming && !(welcome_.world == before))
    return make_error(ErrorCode::kUnsupported, "welcome.world", "the server hosts a different world now");
  const uint64_t floor = welcome_.resume_key_known ? last_event_seq_ : last_seen_seq_;
  if (resuming && welcome_.global_sequence < floor)
    return make_error(ErrorCode::kUnsupported, "welcome.global_sequence",
                      "the server is at sequence " + std::to_string(welcome_.global_sequence) +
                          ", behind the " + std::to_string(floor) +
                          " this client saw: not the session it left");
  // The base version 0 is, when this program can generate it: untouched tiles are made here.
  base_.reset();
  if (welcome_.base_identity != 0 && base_provider_) {
    base_ = base_provider_(welcome_.base_identity);
    if (base_ && base_->identity() != welcome_.base_identity) base_.reset();
  }
  // Deforms in flight on a lost connection go again, first, when the server still knows our
  // resume key (answered once, applied once); after a restart it may have logged them
  // already, so they are dropped (at most once). Then the queued ones.
  // A dropped Deform's answer says so (AckResult::lost), so whoever waits on it stops waiting.
  if (welcome_.resume_key_known) {
    (void)pacer_.requeue_unacked();
  } else {
    for (const uint32_t seq : pacer_.drop_unacked())
      acks_[seq] = AckResult{false, 0, wire::WireErrorCode::kIo, "connection.lost", true};
  }
  pacer_.set_limits(welcome_.limits.max_pending_deforms, double(welcome_.limits.max_deforms_per_second),
                    DeformPacer::Clock::now());
  return send_paced();
}

Status TerrainClient::send_paced() {
  for (auto& [seq, stamp] : pacer_.take_sendable(DeformPacer::Clock::now()))
    LOAM_TRY(connection_->send(wire::Deform{seq, std::move(stamp)}));
  return {};
}

Status TerrainClient::connect(const std::string& host, uint16_t port, const std::string& name,
                              wire::Role role, std::optional<wire::AccessToken> token) {
  name_ = name;
  role_ = role;
  token_ = token;
  if (resume_key_ == 0) {
    std::random_device rd;
    while (resume_key_ == 0) resume_key_ = (uint64_t(rd()) << 32) ^ uint64_t(rd());
  }
  store_.reset();  // a fresh session: nothing to resume
  LOAM_TRY(handshake(host, port));
  store_ = std::make_unique<ConfirmedStore>(welcome_.world);
  last_seen_seq_ = welcome_.global_sequence;
  return {};
}

Status TerrainClient::reconnect(const std::string& host, uint16_t port) {
  if (!store_) return make_error(ErrorCode::kInvalidArgument, "reconnect", "never connected");
  connection_ = std::make_unique<Connection>();
  assemblers_.clear();  // a region cut off mid-transfer is requested again below
  behind_.clear();
  LOAM_TRY(handshake(host, port));
  std::vector<TileCoord> tiles = store_->wanted();
  return subscribe(tiles);
}

std::vector<TileCoord> TerrainClient::all_coarse_tiles(int32_t mip) const {
  std::vector<TileCoord> out;
  const RectI t = welcome_.world.tile_range(mip);
  for (int64_t ty = t.y0; ty < t.y1; ++ty) {
    for (int64_t tx = t.x0; tx < t.x1; ++tx)
      out.push_back({Layer::kCoarse, uint8_t(mip), int32_t(tx), int32_t(ty)});
  }
  return out;
}

Status TerrainClient::subscribe(const std::vector<TileCoord>& tiles, std::optional<wire::Focus> focus) {
  wire::Subscribe sub;
  sub.focus = focus;
  if (tiles.empty() && focus) return connection_->send(sub);  // the focus alone moved
  for (const TileCoord& c : tiles) {
    store_->want(c);
    const WorldParams& w = welcome_.world;
    if (base_ && layer_tile_range(w, c.layer, c.mip).contains(c.tx, c.ty) &&
        !store_->version(c).has_value()) {
      // Version 0 is the base's: this tile's is generated (a layer without a base: all zero,
      // as over a base) and claimed, nothing to download.
      LOAM_TRY(visit_layer(c.layer, [&](auto row) -> Status {
        using R = decltype(row);
        std::vector<typename R::Sample> samples(static_cast<size_t>(kTileSamples));
        if constexpr (R::kHasBase) base_->coarse_tile(c.mip, c.tx, c.ty, samples);
        return store_->replace<R>(c, 0, samples);
      }));
      ++tiles_generated_;
    }
    const auto held = store_->version(c);
    sub.entries.push_back({c, held.has_value(), held.value_or(0)});
    if (sub.entries.size() == wire::kMaxSubscribeEntries) {
      LOAM_TRY(connection_->send(sub));
      sub.entries.clear();
    }
  }
  if (!sub.entries.empty()) LOAM_TRY(connection_->send(sub));
  return {};
}

Status TerrainClient::unsubscribe(const std::vector<TileCoord>& tiles) {
  wire::Unsubscribe u;
  for (const TileCoord& c : tiles) {
    store_->forget(c);
    behind_.erase(c);
    assemblers_.erase(c);
    u.tiles.push_back(c);
    if (u.tiles.size() == wire::kMaxSubscribeEntries) {
      LOAM_TRY(connection_->send(u));
      u.tiles.clear();
    }
  }
  if (!u.tiles.empty()) LOAM_TRY(connection_->send(u));
  return {};
}

Result<uint32_t> TerrainClient::deform(const QuantizedStamp& stamp) {
  const uint32_t seq = next_client_seq_++;
  pacer_.submit(seq, stamp);
  // A lost connection shows in pump(); the Deform then waits for the next one (reconnect).
  (void)send_paced();
  return seq;
}

Status TerrainClient::on_region_chunk(const wire::RegionUpdate& r) {
  auto done = assemblers_[r.tile].add(r);
  if (!done) return done.error();
  if (!done->has_value()) return {};
  const std::vector<uint8_t> payload = std::move(**done);
  // A patch applies to the tile held at base_version; held at another (an earlier region lost,
  // say), the tile is re-requested whole below.
  const Status st = store_->apply_region(r, payload);
  if (!st.ok() && r.patch && store_->wanted_tile(r.tile)) {
    wire::Subscribe sub;
    sub.entries.push_back({r.tile, false, 0});
    (void)connection_->send(sub);
  }
  return st;
}

Status TerrainClient::request_missing_textures() {
  for (uint64_t id : store_->take_missing_textures()) {
    if (textures_requested_.insert(id).second) LOAM_TRY(connection_->send(wire::StampImageRequest{id}));
  }
  return {};
}

Status TerrainClient::on_stamp_image(const wire::StampImageResponse& r) {
  auto give_up = [&](Error why) -> Status {
    // Without the image its stamps cannot be reproduced here: take the tiles they changed whole.
    wire::Subscribe sub;
    for (const TileCoord& c : store_->tiles_waiting_for(r.image_id)) sub.entries.push_back({c, false, 0});
    if (!sub.entries.empty()) LOAM_TRY(connection_->send(sub));
    return why;
  };
  if (!textures_requested_.count(r.image_id)) return {};  // not asked for
  if (!r.found)
    return give_up(make_error(ErrorCode::kNotFound, "stamp_image", "the server has no such image"));
  const size_t n = size_t(r.width) * size_t(r.height);
  std::vector<uint16_t> samples(n);
  if (r.format == wire::StampImageFormat::kGray16) {
    if (r.pixels.size() != n * 2)
      return give_up(make_error(ErrorCode::kCorrupt, "stamp_image.pixels", "size"));
    for (size_t i = 0; i < n; ++i) samples[i] = load_le<uint16_t>(r.pixels.data() + 2 * i);
  } else {
    if (r.pixels.size() != n) return give_up(make_error(ErrorCode::kCorrupt, "stamp_image.pixels", "size"));
    for (size_t i = 0; i < n; ++i) samples[i] = uint16_t(r.pixels[i] * 257);
  }
  auto id = textures_.add(int32_t(r.width), int32_t(r.height), samples);
  if (!id) return give_up(id.error());
  if (*id != r.image_id) {
    return give_up(
        make_error(ErrorCode::kCorrupt, "stamp_image.image_id", "the pixels do not have this content id"));
  }
  store_->textures_arrived(&textures_);
  return request_missing_textures();
}

Status TerrainClient::handle(wire::Message& m) {
  switch (wire::message_type(m)) {
    case wire::MessageType::kRegionUpdate:
      ++region_chunks_received_;
      return on_region_chunk(std::get<wire::RegionUpdate>(m));
    case wire::MessageType::kDeformEvent: {
      const auto& e = std::get<wire::DeformEvent>(m);
      last_seen_seq_ = std::max(last_seen_seq_, e.global_seq);
      last_event_seq_ = std::max(last_event_seq_, e.global_seq);
      store_->on_event(e, &textures_);
      return request_missing_textures();
    }
    case wire::MessageType::kDeformAck: {
      const auto& a = std::get<wire::DeformAck>(m);
      acks_[a.client_seq] = AckResult{a.accepted, a.global_seq, a.reject_code, a.field};
      pacer_.acknowledged(a.client_seq);
      if (a.accepted) last_seen_seq_ = std::max(last_seen_seq_, a.global_seq);
      return {};
    }
    case wire::MessageType::kTileHashes: {
      ++tile_hash_messages_;
      const auto& hashes = std::get<wire::TileHashes>(m);
      wire::Subscribe sub;
      // Held at the server's version with other samples: corrupt. Ask for the tile again as if
      // we held nothing.
      for (const TileCoord& c : store_->check_hashes(hashes)) sub.entries.push_back({c, false, 0});
      // Held at an older version: a region may still be on its way (the server streams under a
      // byte budget), but still behind at the same version one round later, nothing came for
      // it: a change was lost. Claim the version held, so the server sends what changed since.
      for (const wire::TileHashEntry& e : hashes.entries) {
        const auto held = store_->version(e.tile);
        if (!held || *held >= e.version) {
          behind_.erase(e.tile);
          continue;
        }
        const auto [it, first] = behind_.try_emplace(e.tile, *held);
        if (first || it->second != *held) {
          it->second = *held;
          continue;
        }
        sub.entries.push_back({e.tile, true, *held});
        behind_.erase(it);
      }
      if (sub.entries.empty()) return {};
      return connection_->send(sub);
    }
    case wire::MessageType::kStampImageResponse: return on_stamp_image(std::get<wire::StampImageResponse>(m));
    case wire::MessageType::kError: errors_.push_back(std::get<wire::ErrorMsg>(m)); return {};
    case wire::MessageType::kBye: bye_ = std::get<wire::Bye>(m); return {};
    case wire::MessageType::kPing:
      return connection_->send(wire::Pong{std::get<wire::Ping>(m).client_time_us, 0});
    case wire::MessageType::kPong: {
      const uint64_t sent = std::get<wire::Pong>(m).client_time_us, now = steady_us();
      if (sent != 0 && sent <= now) rtt_ms_ = double(now - sent) / 1000.0;
      return {};
    }
    case wire::MessageType::kStampImageList: {
      const auto& list = std::get<wire::StampImageList>(m);
      if (list.request_id != image_list_request_id_) return {};
      stamp_images_ = list.images;
      for (const wire::StampImageListEntry& e : stamp_images_) {
        const bool served = e.width <= wire::kMaxStampImageSide && e.height <= wire::kMaxStampImageSide;
        if (served && !textures_.contains(e.image_id) && textures_requested_.insert(e.image_id).second)
          LOAM_TRY(connection_->send(wire::StampImageRequest{e.image_id}));
      }
      return {};
    }
    case wire::MessageType::kStats:
      if (std::get<wire::Stats>(m).request_id == stats_request_id_) server_stats_ = std::get<wire::Stats>(m);
      return {};
    default: return {};
  }
}

Status TerrainClient::ping() { return connection_->send(wire::Ping{steady_us()}); }

Status TerrainClient::request_stamp_images() {
  return connection_->send(wire::StampImageListRequest{++image_list_request_id_});
}

Status TerrainClient::request_stats() { return connection_->send(wire::StatsRequest{++stats_request_id_}); }

Status TerrainClient::pump(std::chrono::milliseconds timeout) {
  // A queued Deform due before the timeout cuts the wait short, so the pacing keeps its rate.
  if (const auto due = pacer_.next_send_time()) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(*due - DeformPacer::Clock::now());
    timeout = std::clamp(left + std::chrono::milliseconds(1), std::chrono::milliseconds(0), timeout);
  }
  // Messages until the inbox is empty or the timeout has passed: a client slower than what
  // arrives still gets control back (to send, to render, to stop).
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  auto m = connection_->next(timeout);
  while (true) {
    if (!m) return m.error();
    if (!m->has_value()) return send_paced();
    if (const Status st = handle(**m); !st.ok()) {
      // A message we could not use (a region that fails its checks, say) is recorded and
      // repaired by the next hash check; it does not end the session.
      local_errors_.push_back(st.error());
    }
    if (std::chrono::steady_clock::now() >= deadline) return send_paced();
    m = connection_->next(std::chrono::milliseconds(0));
  }
}

bool TerrainClient::wait_until(const std::function<bool()>& pred, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return false;
    if (!pump(std::min(left, std::chrono::milliseconds(50))).ok()) return pred();
  }
  return true;
}

std::optional<AckResult> TerrainClient::ack(uint32_t client_seq) const {
  const auto it = acks_.find(client_seq);
  if (it == acks_.end()) return std::nullopt;
  return it->second;
}

}  // namespace loam::client
