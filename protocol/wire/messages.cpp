#include "protocol/wire/messages.h"

#include <algorithm>
#include <utility>

#include "protocol/stamps/texture_registry.h"
#include "protocol/wire/byte_stream.h"
#include "protocol/wire/fields.h"

namespace loam::wire {

const char* to_string(MessageType type) {
  switch (type) {
    case MessageType::kHello: return "Hello";
    case MessageType::kWelcome: return "Welcome";
    case MessageType::kError: return "Error";
    case MessageType::kPing: return "Ping";
    case MessageType::kPong: return "Pong";
    case MessageType::kBye: return "Bye";
    case MessageType::kSubscribe: return "Subscribe";
    case MessageType::kUnsubscribe: return "Unsubscribe";
    case MessageType::kDeform: return "Deform";
    case MessageType::kDeformAck: return "DeformAck";
    case MessageType::kDeformEvent: return "DeformEvent";
    case MessageType::kRegionUpdate: return "RegionUpdate";
    case MessageType::kTileHashes: return "TileHashes";
    case MessageType::kStampImageRequest: return "StampImageRequest";
    case MessageType::kStatsRequest: return "StatsRequest";
    case MessageType::kStats: return "Stats";
    case MessageType::kStampImageResponse: return "StampImageResponse";
    case MessageType::kStampImageListRequest: return "StampImageListRequest";
    case MessageType::kStampImageList: return "StampImageList";
  }
  return "unknown";
}

const char* to_string(Role role) {
  switch (role) {
    case Role::kPlayer: return "player";
    case Role::kSpectator: return "spectator";
    case Role::kBot: return "bot";
    case Role::kAdmin: return "admin";
  }
  return "unknown";
}

bool is_known(WireErrorCode code) {
  const auto v = static_cast<uint16_t>(code);
  return (v >= 1 && v <= 11) || (v >= 32 && v <= 36);
}

const char* to_string(WireErrorCode code) {
  switch (code) {
    case WireErrorCode::kInvalidArgument: return "invalid argument";
    case WireErrorCode::kNotFinite: return "not finite";
    case WireErrorCode::kTruncated: return "truncated";
    case WireErrorCode::kOversize: return "oversize";
    case WireErrorCode::kBadEnum: return "bad enum";
    case WireErrorCode::kUnknownType: return "unknown type";
    case WireErrorCode::kUnsupported: return "unsupported";
    case WireErrorCode::kCorrupt: return "corrupt";
    case WireErrorCode::kIo: return "i/o error";
    case WireErrorCode::kNotFound: return "not found";
    case WireErrorCode::kUnauthorized: return "unauthorized";
    case WireErrorCode::kRateLimited: return "rate limited";
    case WireErrorCode::kServerFull: return "server full";
    case WireErrorCode::kOutOfWorld: return "out of world";
    case WireErrorCode::kTooManyPending: return "too many pending deforms";
    case WireErrorCode::kInternal: return "internal error";
  }
  return "unknown error";
}

WireErrorCode to_wire(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidArgument: return WireErrorCode::kInvalidArgument;
    case ErrorCode::kNotFinite: return WireErrorCode::kNotFinite;
    case ErrorCode::kTruncated: return WireErrorCode::kTruncated;
    case ErrorCode::kOversize: return WireErrorCode::kOversize;
    case ErrorCode::kBadEnum: return WireErrorCode::kBadEnum;
    case ErrorCode::kUnknownType: return WireErrorCode::kUnknownType;
    case ErrorCode::kUnsupported: return WireErrorCode::kUnsupported;
    case ErrorCode::kCorrupt: return WireErrorCode::kCorrupt;
    case ErrorCode::kIo: return WireErrorCode::kIo;
    case ErrorCode::kNotFound: return WireErrorCode::kNotFound;
    case ErrorCode::kUnauthorized: return WireErrorCode::kUnauthorized;
    case ErrorCode::kBusy: return WireErrorCode::kRateLimited;
  }
  return WireErrorCode::kInternal;
}

ErrorCode from_wire(WireErrorCode code) {
  switch (code) {
    case WireErrorCode::kInvalidArgument: return ErrorCode::kInvalidArgument;
    case WireErrorCode::kNotFinite: return ErrorCode::kNotFinite;
    case WireErrorCode::kTruncated: return ErrorCode::kTruncated;
    case WireErrorCode::kOversize: return ErrorCode::kOversize;
    case WireErrorCode::kBadEnum: return ErrorCode::kBadEnum;
    case WireErrorCode::kUnknownType: return ErrorCode::kUnknownType;
    case WireErrorCode::kUnsupported: return ErrorCode::kUnsupported;
    case WireErrorCode::kCorrupt: return ErrorCode::kCorrupt;
    case WireErrorCode::kIo: return ErrorCode::kIo;
    case WireErrorCode::kNotFound: return ErrorCode::kNotFound;
    case WireErrorCode::kUnauthorized: return ErrorCode::kUnauthorized;
    // Capacity refusals are not authorization failures: a client retries these later, while
    // an unauthorized one must not.
    case WireErrorCode::kRateLimited:
    case WireErrorCode::kServerFull:
    case WireErrorCode::kTooManyPending: return ErrorCode::kBusy;
    case WireErrorCode::kOutOfWorld: return ErrorCode::kInvalidArgument;
    case WireErrorCode::kInternal: return ErrorCode::kIo;
  }
  return ErrorCode::kIo;
}

namespace {

// Serialize functions never assign to a message while writing or measuring (every
// assignment sits under `if constexpr (S::kReading)`), which is what lets encode_payload
// run them on a const message.

template <typename S>
Status serialize_error_code(S& s, WireErrorCode& code, const char* field) {
  uint16_t raw = static_cast<uint16_t>(code);
  LOAM_TRY(s.bits(raw, field));
  if (!is_known(static_cast<WireErrorCode>(raw))) {
    return make_error(ErrorCode::kBadEnum, field, "unknown error code " + std::to_string(raw));
  }
  if constexpr (S::kReading) code = static_cast<WireErrorCode>(raw);
  return {};
}

// A u32 count then each element. The reader sizes the vector only after count() proved the
// count is within cap and that the remaining bytes can hold that many elements.
template <typename S, typename T, typename F>
Status serialize_vector(S& s, std::vector<T>& v, uint32_t cap, size_t min_bytes_each, const char* field,
                        F&& each) {
  if constexpr (!S::kReading) {
    if (v.size() > cap) return oversize_error(field, v.size(), cap);
  }
  uint32_t n = static_cast<uint32_t>(v.size());
  LOAM_TRY(s.count(n, cap, min_bytes_each, field));
  if constexpr (S::kReading) v.resize(n);
  for (T& e : v) LOAM_TRY(each(e));
  return {};
}

Error version_error(const char* field, uint16_t peer_major, uint16_t peer_minor) {
  return make_error(ErrorCode::kUnsupported, field,
                    "peer speaks protocol " + std::to_string(peer_major) + "." + std::to_string(peer_minor) +
                        ", this side speaks " + std::to_string(kProtocolMajor) + "." +
                        std::to_string(kProtocolMinor));
}

template <typename S>
Status serialize(S& s, Hello& m) {
  // Magic and version come first and keep this layout in every future major version, so a
  // server can always tell an old or new client what went wrong.
  uint32_t magic = kHelloMagic;
  LOAM_TRY(s.bits(magic, "hello.magic"));
  if (magic != kHelloMagic) {
    return make_error(ErrorCode::kCorrupt, "hello.magic", "not a Loam client (bad magic)");
  }
  LOAM_TRY(s.bits(m.version_major, "hello.version_major"));
  LOAM_TRY(s.bits(m.version_minor, "hello.version_minor"));
  // Checked on read only: the rest of the layout is unknowable for another major version,
  // while a test may still want to encode a foreign Hello.
  if constexpr (S::kReading) {
    if (m.version_major != kProtocolMajor) {
      return version_error("hello.version_major", m.version_major, m.version_minor);
    }
  }
  LOAM_TRY(s.string(m.client_name, kMaxClientNameBytes, "hello.client_name"));
  LOAM_TRY(serialize_enum(s, m.requested_role, kRoleCount, "hello.requested_role"));
  bool has_token = m.access_token.has_value();
  LOAM_TRY(s.boolean(has_token, "hello.has_access_token"));
  if (has_token) {
    if constexpr (S::kReading) m.access_token.emplace();
    LOAM_TRY(s.bytes(m.access_token->data(), kAccessTokenBytes, "hello.access_token"));
  }
  LOAM_TRY(s.bits(m.resume_key, "hello.resume_key"));
  return {};
}

template <typename S>
Status serialize(S& s, ServerLimits& m) {
  LOAM_TRY(serialize_range<uint32_t>(s, m.max_frame_bytes, 1024, kAbsoluteMaxFrameBytes,
                                     "welcome.limits.max_frame_bytes"));
  LOAM_TRY(s.bits(m.max_subscribed_tiles, "welcome.limits.max_subscribed_tiles"));
  LOAM_TRY(s.bits(m.max_pending_deforms, "welcome.limits.max_pending_deforms"));
  LOAM_TRY(s.bits(m.max_deforms_per_second, "welcome.limits.max_deforms_per_second"));
  return {};
}

template <typename S>
Status serialize(S& s, Welcome& m) {
  LOAM_TRY(s.bits(m.version_major, "welcome.version_major"));
  LOAM_TRY(s.bits(m.version_minor, "welcome.version_minor"));
  if constexpr (S::kReading) {
    if (m.version_major != kProtocolMajor) {
      return version_error("welcome.version_major", m.version_major, m.version_minor);
    }
  }
  LOAM_TRY(s.bits(m.client_id, "welcome.client_id"));
  LOAM_TRY(serialize_enum(s, m.granted_role, kRoleCount, "welcome.granted_role"));
  LOAM_TRY(serialize_world_params(s, m.world));
  LOAM_TRY(s.bits(m.global_sequence, "welcome.global_sequence"));
  LOAM_TRY(serialize_range<uint16_t>(s, m.tick_rate_hz, 1, 1000, "welcome.tick_rate_hz"));
  LOAM_TRY(serialize(s, m.limits));
  LOAM_TRY(s.boolean(m.resume_key_known, "welcome.resume_key_known"));
  LOAM_TRY(s.bits(m.base_identity, "welcome.base_identity"));
  return {};
}

template <typename S>
Status serialize(S& s, ErrorMsg& m) {
  LOAM_TRY(serialize_error_code(s, m.code, "error.code"));
  LOAM_TRY(s.string(m.field, kMaxFieldNameBytes, "error.field"));
  LOAM_TRY(s.string(m.text, kMaxErrorTextBytes, "error.text"));
  return {};
}

template <typename S>
Status serialize(S& s, Ping& m) {
  return s.bits(m.client_time_us, "ping.client_time_us");
}

template <typename S>
Status serialize(S& s, Pong& m) {
  LOAM_TRY(s.bits(m.client_time_us, "pong.client_time_us"));
  LOAM_TRY(s.bits(m.server_time_us, "pong.server_time_us"));
  return {};
}

template <typename S>
Status serialize(S& s, Bye& m) {
  LOAM_TRY(serialize_enum(s, m.reason, kByeReasonCount, "bye.reason"));
  LOAM_TRY(s.string(m.text, kMaxErrorTextBytes, "bye.text"));
  return {};
}

template <typename S>
Status serialize(S& s, Subscribe& m) {
  const Status entries =
      serialize_vector(s, m.entries, kMaxSubscribeEntries, kTileCoordBytes + 9, "subscribe.count",
                       [&](SubscribeEntry& e) -> Status {
                         LOAM_TRY(serialize_tile(s, e.tile));
                         LOAM_TRY(s.boolean(e.held, "subscribe.held"));
                         LOAM_TRY(s.bits(e.held_version, "subscribe.held_version"));
                         if (!e.held && e.held_version != 0) {
                           return make_error(ErrorCode::kInvalidArgument, "subscribe.held_version",
                                             "must be 0 when the tile is not held");
                         }
                         return {};
                       });
  if (!entries.ok()) return entries;
  bool has_focus = m.focus.has_value();
  LOAM_TRY(s.boolean(has_focus, "subscribe.has_focus"));
  if (has_focus) {
    if constexpr (S::kReading) m.focus.emplace();
    LOAM_TRY(s.f64(m.focus->x_m, "subscribe.focus_x"));
    LOAM_TRY(s.f64(m.focus->y_m, "subscribe.focus_y"));
  } else if constexpr (S::kReading) {
    m.focus.reset();
  }
  return {};
}

template <typename S>
Status serialize(S& s, Unsubscribe& m) {
  return serialize_vector(s, m.tiles, kMaxSubscribeEntries, kTileCoordBytes, "unsubscribe.count",
                          [&](TileCoord& t) { return serialize_tile(s, t); });
}

template <typename S>
Status serialize(S& s, Deform& m) {
  LOAM_TRY(s.bits(m.client_seq, "deform.client_seq"));
  return serialize_stamp(s, m.stamp);
}

template <typename S>
Status serialize(S& s, DeformAck& m) {
  LOAM_TRY(s.bits(m.client_seq, "deform_ack.client_seq"));
  LOAM_TRY(s.boolean(m.accepted, "deform_ack.accepted"));
  if (m.accepted) {
    LOAM_TRY(s.bits(m.global_seq, "deform_ack.global_seq"));
    if (m.global_seq == 0) {
      return make_error(ErrorCode::kInvalidArgument, "deform_ack.global_seq", "must be > 0 when accepted");
    }
  } else {
    LOAM_TRY(serialize_error_code(s, m.reject_code, "deform_ack.reject_code"));
    LOAM_TRY(s.string(m.field, kMaxFieldNameBytes, "deform_ack.field"));
  }
  return {};
}

// Compact (protocol 3): a stamp causes one event per client, so its bytes are the price of an
// edit. Varints throughout; each tile travels as its layer and mip (one byte), its offset
// from the tile holding the stamp's center at that mip (one byte for all but huge stamps) and
// the distance of its base version below the event's sequence. docs/protocol.md, "DeformEvent".
template <typename S>
Status serialize(S& s, DeformEvent& m) {
  LOAM_TRY(serialize_uvarint<uint64_t>(s, m.global_seq, "deform_event.global_seq", 1, UINT64_MAX));
  LOAM_TRY(serialize_uvarint(s, m.origin_client_id, "deform_event.origin_client_id"));
  LOAM_TRY(serialize_stamp_compact(s, m.stamp));
  if (m.stamp.kind == StampKind::kFootprint) {
    LOAM_TRY(s.boolean(m.contact.touches, "deform_event.contact"));
    if (m.contact.touches) {
      LOAM_TRY(serialize_svarint(s, m.contact.height_q8, "deform_event.contact_height"));
    } else if constexpr (S::kReading) {
      m.contact.height_q8 = 0;
    }
  } else if constexpr (S::kReading) {
    m.contact = {};
  }
  uint64_t n = m.base_versions.size();
  LOAM_TRY(s.varint(n, "deform_event.tile_count"));
  if (n > kMaxEventTiles) return oversize_error("deform_event.tile_count", n, kMaxEventTiles);
  if constexpr (S::kReading) {
    // Each tile takes at least 3 bytes: never allocate for tiles the frame cannot hold.
    if (n * 3 > s.remaining())
      return truncated_error("deform_event.tile_count", size_t(n * 3), s.offset(), s.remaining());
    m.base_versions.resize(n);
  }
  const TileVersion* prev = nullptr;
  for (TileVersion& t : m.base_versions) {
    uint8_t key = uint8_t(uint8_t(t.tile.layer) << 7 | t.tile.mip);
    LOAM_TRY(s.bits(key, "deform_event.tile"));
    if constexpr (S::kReading) {
      t.tile.layer = Layer(key >> 7);
      t.tile.mip = uint8_t(key & 0x7F);
    }
    if (t.tile.mip >= kMaxMips || !layer_has_mip(t.tile.layer, t.tile.mip))
      return make_error(ErrorCode::kInvalidArgument, "deform_event.tile", "no such layer and mip");
    const int64_t span = int64_t(kTileSize) << (kPositionFracBits + t.tile.mip);
    const int64_t ax = floor_div(m.stamp.center_x, span), ay = floor_div(m.stamp.center_y, span);
    int64_t dx = int64_t(t.tile.tx) - ax, dy = int64_t(t.tile.ty) - ay;
    // One byte for offsets in [-7, 7] (every tile of a stamp up to ~1,800 samples across);
    // 255 then both as zigzag varints. Codes 225..254 are unused and refused.
    const bool small = dx >= -7 && dx <= 7 && dy >= -7 && dy <= 7;
    uint8_t code = small ? uint8_t((dx + 7) * 15 + (dy + 7)) : 255;
    LOAM_TRY(s.bits(code, "deform_event.tile_offset"));
    if (code == 255) {
      LOAM_TRY(serialize_svarint(s, dx, "deform_event.tile_dx"));
      LOAM_TRY(serialize_svarint(s, dy, "deform_event.tile_dy"));
      if (dx >= -7 && dx <= 7 && dy >= -7 && dy <= 7)
        return make_error(ErrorCode::kCorrupt, "deform_event.tile_offset", "small offsets written long");
    } else if (code >= 225) {
      return make_error(ErrorCode::kCorrupt, "deform_event.tile_offset", "unused offset code");
    } else if constexpr (S::kReading) {
      dx = code / 15 - 7;
      dy = code % 15 - 7;
    }
    if constexpr (S::kReading) {
      // dx and dy are any int64 a hostile frame writes: the sum is checked, never overflowed.
      int64_t tx = 0, ty = 0;
      if (__builtin_add_overflow(ax, dx, &tx) || __builtin_add_overflow(ay, dy, &ty) || tx < INT32_MIN ||
          tx > INT32_MAX || ty < INT32_MIN || ty > INT32_MAX)
        return make_error(ErrorCode::kInvalidArgument, "deform_event.tile_dx",
                          "tile coordinate out of range");
      t.tile.tx = int32_t(tx);
      t.tile.ty = int32_t(ty);
    }
    // A base version at or after the event itself cannot exist: the distance is >= 1.
    if constexpr (!S::kReading) {
      if (t.version >= m.global_seq)
        return make_error(ErrorCode::kInvalidArgument, "deform_event.base_version", "must be < global_seq");
    }
    uint64_t below = m.global_seq - t.version;
    LOAM_TRY(serialize_uvarint<uint64_t>(s, below, "deform_event.base_version", 1, m.global_seq));
    if constexpr (S::kReading) t.version = m.global_seq - below;
    // Sorted and distinct: one encoding per event, and no tile listed twice.
    if (prev && !(prev->tile < t.tile))
      return make_error(ErrorCode::kInvalidArgument, "deform_event.tile", "tiles not in ascending order");
    prev = &t;
  }
  return {};
}

uint32_t bytes_per_sample(Layer layer) { return uint32_t(layer_info(layer).bytes_per_sample); }

template <typename S>
Status serialize(S& s, RegionUpdate& m) {
  LOAM_TRY(serialize_tile(s, m.tile));
  LOAM_TRY(serialize_tile_rect(s, m.rect));
  LOAM_TRY(s.boolean(m.patch, "region.patch"));
  LOAM_TRY(s.bits(m.base_version, "region.base_version"));
  LOAM_TRY(s.bits(m.new_version, "region.new_version"));
  // A replacement is the whole tile at any version (0 = initial terrain); a patch moves a held
  // version forward.
  if (!m.patch && (m.base_version != 0 || !(m.rect == RectI{0, 0, kTileSize, kTileSize}))) {
    return make_error(ErrorCode::kInvalidArgument,
                      m.base_version != 0 ? "region.base_version" : "region.rect",
                      "a replacement covers the whole tile and has no base version");
  }
  if (m.patch && m.new_version <= m.base_version) {
    return make_error(ErrorCode::kInvalidArgument, "region.new_version",
                      "must be > base_version for a patch");
  }
  LOAM_TRY(serialize_enum(s, m.encoding, kRegionEncodingCount, "region.encoding"));
  LOAM_TRY(serialize_range<uint32_t>(s, m.total_bytes, 0, kMaxRegionPayloadBytes, "region.total_bytes"));
  if (m.encoding == RegionEncoding::kRaw &&
      uint64_t(m.total_bytes) != uint64_t(m.rect.area()) * bytes_per_sample(m.tile.layer)) {
    return make_error(ErrorCode::kCorrupt, "region.total_bytes", "raw payload size does not match the rect");
  }
  LOAM_TRY(s.bits(m.chunk_offset, "region.chunk_offset"));
  LOAM_TRY(s.blob(m.chunk, kMaxRegionChunkBytes, "region.chunk"));
  // 64-bit sum: offset and size are each below 2^32, so this cannot wrap.
  if (uint64_t(m.chunk_offset) + m.chunk.size() > m.total_bytes) {
    return make_error(ErrorCode::kCorrupt, "region.chunk_offset", "chunk extends past total_bytes");
  }
  return {};
}

template <typename S>
Status serialize(S& s, TileHashes& m) {
  return serialize_vector(s, m.entries, kMaxTileHashEntries, kTileCoordBytes + 16, "tile_hashes.count",
                          [&](TileHashEntry& e) -> Status {
                            LOAM_TRY(serialize_tile(s, e.tile));
                            LOAM_TRY(s.bits(e.version, "tile_hashes.version"));
                            return s.bits(e.hash, "tile_hashes.hash");
                          });
}

template <typename S>
Status serialize(S& s, StampImageRequest& m) {
  return s.bits(m.image_id, "stamp_image_request.image_id");
}

template <typename S>
Status serialize(S& s, StampImageResponse& m) {
  LOAM_TRY(s.bits(m.image_id, "stamp_image.image_id"));
  LOAM_TRY(s.boolean(m.found, "stamp_image.found"));
  if (!m.found) return {};
  LOAM_TRY(serialize_range<uint16_t>(s, m.width, 1, kMaxStampImageSide, "stamp_image.width"));
  LOAM_TRY(serialize_range<uint16_t>(s, m.height, 1, kMaxStampImageSide, "stamp_image.height"));
  LOAM_TRY(serialize_enum(s, m.format, kStampImageFormatCount, "stamp_image.format"));
  LOAM_TRY(s.blob(m.pixels, kMaxStampImageBytes, "stamp_image.pixels"));
  const uint64_t expect = uint64_t(m.width) * m.height * (m.format == StampImageFormat::kGray16 ? 2u : 1u);
  if (m.pixels.size() != expect) {
    return make_error(ErrorCode::kCorrupt, "stamp_image.pixels",
                      std::to_string(m.pixels.size()) + " bytes for a " + std::to_string(m.width) + "x" +
                          std::to_string(m.height) + " image, expected " + std::to_string(expect));
  }
  return {};
}

template <typename S>
Status serialize(S& s, StatsRequest& m) {
  return s.bits(m.request_id, "stats_request.request_id");
}

template <typename S>
Status serialize(S& s, Stats& m) {
  LOAM_TRY(s.bits(m.request_id, "stats.request_id"));
  LOAM_TRY(s.bits(m.clients, "stats.clients"));
  LOAM_TRY(s.bits(m.global_sequence, "stats.global_sequence"));
  LOAM_TRY(s.bits(m.deforms_accepted, "stats.deforms_accepted"));
  LOAM_TRY(s.bits(m.deforms_rejected, "stats.deforms_rejected"));
  LOAM_TRY(s.bits(m.violations, "stats.violations"));
  LOAM_TRY(s.bits(m.bytes_in, "stats.bytes_in"));
  LOAM_TRY(s.bits(m.bytes_out, "stats.bytes_out"));
  LOAM_TRY(s.bits(m.tick_overruns, "stats.tick_overruns"));
  LOAM_TRY(s.bits(m.tick_p50_us, "stats.tick_p50_us"));
  LOAM_TRY(s.bits(m.tick_p99_us, "stats.tick_p99_us"));
  LOAM_TRY(s.bits(m.uptime_ms, "stats.uptime_ms"));
  LOAM_TRY(s.bits(m.region_encodes, "stats.region_encodes"));
  LOAM_TRY(s.bits(m.region_cache_hits, "stats.region_cache_hits"));
  LOAM_TRY(s.bits(m.events_sent, "stats.events_sent"));
  LOAM_TRY(s.bits(m.regions_sent, "stats.regions_sent"));
  return s.bits(m.client_bytes_per_second, "stats.client_bytes_per_second");
}

template <typename S>
Status serialize(S& s, StampImageListRequest& m) {
  return s.bits(m.request_id, "stamp_image_list_request.request_id");
}

template <typename S>
Status serialize(S& s, StampImageList& m) {
  LOAM_TRY(s.bits(m.request_id, "stamp_image_list.request_id"));
  return serialize_vector(s, m.images, kMaxStampImageListEntries, 16, "stamp_image_list.count",
                          [&](StampImageListEntry& e) -> Status {
                            LOAM_TRY(s.bits(e.image_id, "stamp_image_list.image_id"));
                            LOAM_TRY(serialize_range<uint32_t>(s, e.width, 1, uint32_t(kMaxTextureSide),
                                                               "stamp_image_list.width"));
                            return serialize_range<uint32_t>(s, e.height, 1, uint32_t(kMaxTextureSide),
                                                             "stamp_image_list.height");
                          });
}

template <size_t I>
Result<Message> decode_as(std::span<const uint8_t> payload) {
  std::variant_alternative_t<I, Message> m;
  ReadStream s(payload);
  LOAM_TRY(serialize(s, m));
  LOAM_TRY(s.expect_end(to_string(MessageType(I + 1))));
  return Message(std::in_place_index<I>, std::move(m));
}

using Decoder = Result<Message> (*)(std::span<const uint8_t>);
template <size_t... I>
constexpr std::array<Decoder, sizeof...(I)> make_decoders(std::index_sequence<I...>) {
  return {&decode_as<I>...};
}
constexpr auto kDecoders = make_decoders(std::make_index_sequence<std::variant_size_v<Message>>());
static_assert(kDecoders.size() == kLastMessageType - kFirstMessageType + 1);

template <typename S>
Status serialize_any(S& s, const Message& m) {
  return std::visit(
      [&](const auto& msg) -> Status {
        using T = std::decay_t<decltype(msg)>;
        return serialize(s, const_cast<T&>(msg));  // read-only on write paths (see above)
      },
      m);
}

}  // namespace

MessageType message_type(const Message& m) { return MessageType(m.index() + 1); }

Result<std::vector<uint8_t>> encode_payload(const Message& m) {
  std::vector<uint8_t> out;
  WriteStream s(out);
  LOAM_TRY(serialize_any(s, m));
  return out;
}

Result<size_t> measure_payload(const Message& m) {
  MeasureStream s;
  LOAM_TRY(serialize_any(s, m));
  return s.offset();
}

Result<std::vector<FieldSpan>> payload_layout(const Message& m) {
  std::vector<FieldSpan> layout;
  MeasureStream s(&layout);
  LOAM_TRY(serialize_any(s, m));
  return layout;
}

Result<Message> decode_payload(uint16_t type, std::span<const uint8_t> payload) {
  if (type < kFirstMessageType || type > kLastMessageType) {
    return make_error(ErrorCode::kUnknownType, "frame.type", "unknown message type " + std::to_string(type));
  }
  return kDecoders[type - kFirstMessageType](payload);
}

ErrorMsg version_mismatch(uint16_t peer_major, uint16_t peer_minor) {
  const Error e = version_error("hello.version_major", peer_major, peer_minor);
  return ErrorMsg{WireErrorCode::kUnsupported, e.field, e.message};
}

ErrorMsg to_error_message(const Error& e) {
  ErrorMsg m{to_wire(e.code), e.field, e.describe()};
  if (m.field.size() > kMaxFieldNameBytes) m.field.resize(kMaxFieldNameBytes);
  if (m.text.size() > kMaxErrorTextBytes) m.text.resize(kMaxErrorTextBytes);
  return m;
}

Result<std::vector<RegionUpdate>> chunk_region(const RegionUpdate& header, std::span<const uint8_t> payload,
                                               uint32_t max_chunk) {
  if (payload.size() > kMaxRegionPayloadBytes) {
    return oversize_error("region.total_bytes", payload.size(), kMaxRegionPayloadBytes);
  }
  if (max_chunk == 0 || max_chunk > kMaxRegionChunkBytes) max_chunk = kMaxRegionChunkBytes;
  std::vector<RegionUpdate> chunks;
  size_t offset = 0;
  do {
    const size_t n = std::min<size_t>(max_chunk, payload.size() - offset);
    RegionUpdate c;
    c.tile = header.tile;
    c.rect = header.rect;
    c.patch = header.patch;
    c.base_version = header.base_version;
    c.new_version = header.new_version;
    c.encoding = header.encoding;
    c.total_bytes = static_cast<uint32_t>(payload.size());
    c.chunk_offset = static_cast<uint32_t>(offset);
    c.chunk.assign(payload.begin() + static_cast<ptrdiff_t>(offset),
                   payload.begin() + static_cast<ptrdiff_t>(offset + n));
    chunks.push_back(std::move(c));
    offset += n;
  } while (offset < payload.size());
  return chunks;
}

Result<std::optional<std::vector<uint8_t>>> RegionAssembler::add(const RegionUpdate& chunk) {
  const auto same_region = [&](const RegionUpdate& a) {
    return a.tile == chunk.tile && a.rect == chunk.rect && a.patch == chunk.patch &&
           a.base_version == chunk.base_version && a.new_version == chunk.new_version &&
           a.encoding == chunk.encoding && a.total_bytes == chunk.total_bytes;
  };
  if (!active_) {
    if (chunk.chunk_offset != 0) {
      return make_error(ErrorCode::kCorrupt, "region.chunk_offset", "first chunk must start at offset 0");
    }
    active_ = true;
    header_ = chunk;
    header_.chunk.clear();
    payload_.clear();
    payload_.reserve(chunk.total_bytes);  // capped by the decoder at kMaxRegionPayloadBytes
  } else if (!same_region(header_) || chunk.chunk_offset != payload_.size()) {
    active_ = false;
    payload_.clear();
    return make_error(ErrorCode::kCorrupt, "region.chunk_offset",
                      "chunk does not continue the region being assembled");
  }
  if (uint64_t(payload_.size()) + chunk.chunk.size() > chunk.total_bytes) {
    active_ = false;
    payload_.clear();
    return make_error(ErrorCode::kCorrupt, "region.chunk", "chunks exceed total_bytes");
  }
  payload_.insert(payload_.end(), chunk.chunk.begin(), chunk.chunk.end());
  if (payload_.size() < chunk.total_bytes) return std::optional<std::vector<uint8_t>>();
  active_ = false;
  return std::optional<std::vector<uint8_t>>(std::move(payload_));
}

}  // namespace loam::wire
