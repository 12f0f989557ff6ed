// Wire messages: plain structs for everything a server and a client exchange, one
// serialize function per message (read, write and measure), and whole-message encode/decode.
// docs/protocol.md gives the byte layout of every message; constants.h holds the ids and caps.
//
// Safe on untrusted input: decode_payload() checks every read against the bytes present,
// every count and length against its cap before allocating, every enumeration against its
// known values and every double for finiteness, and requires the payload to be consumed
// exactly. Failures are Errors naming the field (kTruncated, kOversize, kBadEnum,
// kNotFinite, kUnknownType, kUnsupported, kInvalidArgument, kCorrupt); nothing throws.
// For every message m that encodes, decode_payload(type(m), encode_payload(m)) == m.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/result.h"
#include "protocol/stamps/stamp.h"
#include "protocol/wire/byte_stream.h"
#include "protocol/wire/constants.h"

namespace loam::wire {

// What a client asks to be; the server grants a role in Welcome.
enum class Role : uint8_t { kPlayer = 0, kSpectator = 1, kBot = 2, kAdmin = 3 };
inline constexpr uint32_t kRoleCount = 4;
const char* to_string(Role role);

// Error codes on the wire. Explicit values: they are part of the protocol. The first block
// mirrors loam::ErrorCode (decode and validation failures), the second is protocol-level.
enum class WireErrorCode : uint16_t {
  kInvalidArgument = 1,
  kNotFinite = 2,
  kTruncated = 3,
  kOversize = 4,
  kBadEnum = 5,
  kUnknownType = 6,
  kUnsupported = 7,  // includes an unknown protocol major version
  kCorrupt = 8,
  kIo = 9,
  kNotFound = 10,
  kUnauthorized = 11,
  kRateLimited = 32,
  kServerFull = 33,
  kOutOfWorld = 34,
  kTooManyPending = 35,
  kInternal = 36,
};
bool is_known(WireErrorCode code);
const char* to_string(WireErrorCode code);
WireErrorCode to_wire(ErrorCode code);
ErrorCode from_wire(WireErrorCode code);  // protocol-level codes map to the nearest ErrorCode

enum class ByeReason : uint8_t {
  kNormal = 0,
  kShutdown = 1,
  kTimeout = 2,
  kProtocolError = 3,
  kKicked = 4,
  kVersionMismatch = 5,
};
inline constexpr uint32_t kByeReasonCount = 6;

// Payload encodings of a RegionUpdate. kRaw: row-major little-endian samples of the rect
// (u16 coarse, i8 detail). kCodec: the region codec of protocol/codec (self-describing).
enum class RegionEncoding : uint8_t { kRaw = 0, kCodec = 1 };
inline constexpr uint32_t kRegionEncodingCount = 2;

enum class StampImageFormat : uint8_t { kGray8 = 0, kGray16 = 1 };
inline constexpr uint32_t kStampImageFormatCount = 2;

using AccessToken = std::array<uint8_t, kAccessTokenBytes>;

struct Hello {
  uint16_t version_major = kProtocolMajor;
  uint16_t version_minor = kProtocolMinor;
  std::string client_name;  // <= kMaxClientNameBytes
  Role requested_role = Role::kPlayer;
  // Who may join and in which role (server/access_tokens.h); absent where the server has no
  // tokens. It does not name a session: a reconnecting client resumes its tiles by subscribing
  // with the versions it holds (Subscribe entries with held = true), and its Deforms by its
  // resume key.
  std::optional<AccessToken> access_token;
  // A random number the client keeps across its reconnects (0: none). A Deform resent on a
  // new connection with the same key and client_seq is answered with its first answer and not
  // applied again (exactly once).
  uint64_t resume_key = 0;
  friend bool operator==(const Hello&, const Hello&) = default;
};

struct ServerLimits {
  uint32_t max_frame_bytes = kDefaultMaxFrameBytes;  // applies to both directions
  uint32_t max_subscribed_tiles = 4096;              // total across Subscribe messages
  uint32_t max_pending_deforms = 64;                 // unacknowledged Deforms per client
  uint32_t max_deforms_per_second = 60;
  friend bool operator==(const ServerLimits&, const ServerLimits&) = default;
};

struct Welcome {
  uint16_t version_major = kProtocolMajor;
  uint16_t version_minor = kProtocolMinor;
  uint32_t client_id = 0;
  Role granted_role = Role::kPlayer;
  WorldParams world;
  uint64_t global_sequence = 0;  // last sequence applied by the server
  uint16_t tick_rate_hz = 30;    // > 0
  ServerLimits limits;
  // The server remembers the answers of this client's resume key (it has not restarted since
  // they were given): Deforms sent and never answered may be sent again, and count once.
  // False: they may or may not have been applied; the client must not send them again.
  bool resume_key_known = false;
  // The identity (TileBase::identity) of the base that every tile's version 0 is, when it is
  // one: a client that can generate that base holds any tile at version 0 without a region,
  // and subscribes claiming it. 0: version 0 must come from the server.
  uint64_t base_identity = 0;
  friend bool operator==(const Welcome&, const Welcome&) = default;
};

struct ErrorMsg {
  WireErrorCode code = WireErrorCode::kInternal;
  std::string field;  // <= kMaxFieldNameBytes; the field at fault, may be empty
  std::string text;   // <= kMaxErrorTextBytes; for a human
  friend bool operator==(const ErrorMsg&, const ErrorMsg&) = default;
};

struct Ping {
  uint64_t client_time_us = 0;
  friend bool operator==(const Ping&, const Ping&) = default;
};

struct Pong {
  uint64_t client_time_us = 0;  // echoed from Ping
  uint64_t server_time_us = 0;
  friend bool operator==(const Pong&, const Pong&) = default;
};

struct Bye {
  ByeReason reason = ByeReason::kNormal;
  std::string text;  // <= kMaxErrorTextBytes
  friend bool operator==(const Bye&, const Bye&) = default;
};

struct SubscribeEntry {
  TileCoord tile;
  bool held = false;          // the client holds the tile, at held_version
  uint64_t held_version = 0;  // 0 when not held
  friend bool operator==(const SubscribeEntry&, const SubscribeEntry&) = default;
};

// Where the client looks: its camera's ground position in world meters. The server sends
// pending regions coarsest mip first, then nearest this point (since 3.0).
struct Focus {
  double x_m = 0;
  double y_m = 0;
  friend bool operator==(const Focus&, const Focus&) = default;
};

struct Subscribe {
  std::vector<SubscribeEntry> entries;  // <= kMaxSubscribeEntries
  std::optional<Focus> focus;           // replaces the focus sent before; absent: unchanged
  friend bool operator==(const Subscribe&, const Subscribe&) = default;
};

struct Unsubscribe {
  std::vector<TileCoord> tiles;  // <= kMaxSubscribeEntries
  friend bool operator==(const Unsubscribe&, const Unsubscribe&) = default;
};

struct Deform {
  uint32_t client_seq = 0;  // the client's own counter, echoed in DeformAck
  QuantizedStamp stamp;
  friend bool operator==(const Deform&, const Deform&) = default;
};

struct DeformAck {
  uint32_t client_seq = 0;
  bool accepted = false;
  uint64_t global_seq = 0;                               // when accepted (> 0)
  WireErrorCode reject_code = WireErrorCode::kInternal;  // when rejected
  std::string field;                                     // when rejected: the field at fault
  friend bool operator==(const DeformAck&, const DeformAck&) = default;
};

struct TileVersion {
  TileCoord tile;
  uint64_t version = 0;
  friend bool operator==(const TileVersion&, const TileVersion&) = default;
};

struct DeformEvent {
  uint64_t global_seq = 0;  // > 0
  uint32_t origin_client_id = 0;
  QuantizedStamp stamp;
  // Every tile (each layer and mip) the stamp changes, with its version before the stamp
  // (< global_seq), sorted by tile. Which of them a client must hold at these versions to
  // apply the event is protocol/replication/event_rule.h's rule.
  std::vector<TileVersion> base_versions;  // <= kMaxEventTiles
  // Footprint only: the contact the server measured on the mip-0 terrain, so every mip (and a
  // client that holds only some tiles under the foot) applies the footprint exactly.
  FootprintContact contact;
  friend bool operator==(const DeformEvent&, const DeformEvent&) = default;
};

struct RegionUpdate {
  TileCoord tile;
  RectI rect;                 // tile-local samples, non-empty, inside the tile
  bool patch = false;         // false: the whole tile (rect is all of it); true: rect over base_version
  uint64_t base_version = 0;  // patch: the version of the tile the rect's samples apply to (0 otherwise)
  uint64_t new_version = 0;   // patch: > base_version
  RegionEncoding encoding = RegionEncoding::kRaw;
  uint32_t total_bytes = 0;    // whole payload across chunks, <= kMaxRegionPayloadBytes
  uint32_t chunk_offset = 0;   // where this chunk starts in the payload
  std::vector<uint8_t> chunk;  // <= kMaxRegionChunkBytes; offset + size <= total_bytes
  friend bool operator==(const RegionUpdate&, const RegionUpdate&) = default;
};

struct TileHashEntry {
  TileCoord tile;
  uint64_t version = 0;
  uint64_t hash = 0;  // tile_hash.h
  friend bool operator==(const TileHashEntry&, const TileHashEntry&) = default;
};

struct TileHashes {
  std::vector<TileHashEntry> entries;  // <= kMaxTileHashEntries
  friend bool operator==(const TileHashes&, const TileHashes&) = default;
};

struct StampImageRequest {
  uint64_t image_id = 0;  // content hash (QuantizedStamp::texture_id)
  friend bool operator==(const StampImageRequest&, const StampImageRequest&) = default;
};

struct StampImageResponse {
  uint64_t image_id = 0;
  bool found = false;
  // When found: 1..kMaxStampImageSide each, pixels = width * height * (1 or 2) bytes,
  // row-major, little-endian for kGray16.
  uint16_t width = 0;
  uint16_t height = 0;
  StampImageFormat format = StampImageFormat::kGray8;
  std::vector<uint8_t> pixels;
  friend bool operator==(const StampImageResponse&, const StampImageResponse&) = default;
};

// Asks the server for its counters (answered with Stats). Since protocol 1.1.
struct StatsRequest {
  uint32_t request_id = 0;  // echoed in Stats
  friend bool operator==(const StatsRequest&, const StatsRequest&) = default;
};

// The server's counters since it started, and tick times over the last stats period.
struct Stats {
  uint32_t request_id = 0;
  uint32_t clients = 0;
  uint64_t global_sequence = 0;
  uint64_t deforms_accepted = 0;
  uint64_t deforms_rejected = 0;
  uint64_t violations = 0;
  uint64_t bytes_in = 0;
  uint64_t bytes_out = 0;
  uint64_t tick_overruns = 0;
  uint32_t tick_p50_us = 0;
  uint32_t tick_p99_us = 0;
  uint64_t uptime_ms = 0;
  // Since 3.0: regions encoded and regions served from the encode-once cache; events sent (one
  // encoding each, whatever the number of clients).
  uint64_t region_encodes = 0;
  uint64_t region_cache_hits = 0;
  uint64_t events_sent = 0;
  uint64_t regions_sent = 0;
  // Since 6.0: the bytes per second the server streams regions to the asking client within.
  uint32_t client_bytes_per_second = 0;
  friend bool operator==(const Stats&, const Stats&) = default;
};

// Asks which stamp images the server has registered (answered with StampImageList). Since 6.0.
struct StampImageListRequest {
  uint32_t request_id = 0;  // echoed in StampImageList
  friend bool operator==(const StampImageListRequest&, const StampImageListRequest&) = default;
};

struct StampImageListEntry {
  uint64_t image_id = 0;  // content hash: a texture stamp's texture_id
  uint32_t width = 0;     // pixels, > 0 (may exceed kMaxStampImageSide: such an image is used
  uint32_t height = 0;    // by id but not served by StampImageRequest)
  friend bool operator==(const StampImageListEntry&, const StampImageListEntry&) = default;
};

// The server's registered stamp images, ordered by id (the first kMaxStampImageListEntries).
struct StampImageList {
  uint32_t request_id = 0;
  std::vector<StampImageListEntry> images;
  friend bool operator==(const StampImageList&, const StampImageList&) = default;
};

// Alternative i holds the message whose MessageType is i + 1.
using Message = std::variant<Hello, Welcome, ErrorMsg, Ping, Pong, Bye, Subscribe, Unsubscribe, Deform,
                             DeformAck, DeformEvent, RegionUpdate, TileHashes, StampImageRequest,
                             StampImageResponse, StatsRequest, Stats, StampImageListRequest, StampImageList>;

MessageType message_type(const Message& m);

// Encodes a payload (no frame header). Fails with the same typed Error a decoder would give
// when the message breaks a cap or range, so nothing undecodable is ever sent.
Result<std::vector<uint8_t>> encode_payload(const Message& m);
// Payload size in bytes, or the encoding error.
Result<size_t> measure_payload(const Message& m);
// Every field of m's payload in order, as the encoder writes it and the decoder reads it (one
// serialize function does both): its name, offset, width and integer value. For tools and for
// the tests that hold docs/protocol.md to the code.
Result<std::vector<FieldSpan>> payload_layout(const Message& m);
// Decodes a payload of a frame whose header said `type`.
Result<Message> decode_payload(uint16_t type, std::span<const uint8_t> payload);

// The error a side sends (then Bye, then close) when the peer's major version differs.
ErrorMsg version_mismatch(uint16_t peer_major, uint16_t peer_minor);
// An Error turned into the ErrorMsg to send (code, field, and describe() as text, capped).
ErrorMsg to_error_message(const Error& e);

// Splits a region payload into RegionUpdate chunks of at most max_chunk bytes (capped at
// kMaxRegionChunkBytes). `header` supplies tile, rect, versions and encoding. An empty
// payload yields one empty chunk.
Result<std::vector<RegionUpdate>> chunk_region(const RegionUpdate& header, std::span<const uint8_t> payload,
                                               uint32_t max_chunk = kMaxRegionChunkBytes);

// Reassembles the chunks of one region. Chunks must arrive in order (the stream is ordered);
// a chunk of a different region or out of order is an error and the partial region is dropped.
// Allocates at most total_bytes, which the decoder already capped.
class RegionAssembler {
 public:
  // Returns the complete payload once the last chunk arrived, std::nullopt before that.
  Result<std::optional<std::vector<uint8_t>>> add(const RegionUpdate& chunk);
  bool in_progress() const { return active_; }

 private:
  bool active_ = false;
  RegionUpdate header_;  // header of the region being assembled (chunk left empty)
  std::vector<uint8_t> payload_;
};

}  // namespace loam::wire
