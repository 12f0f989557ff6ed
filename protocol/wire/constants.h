// Wire constants: protocol version, frame layout, message type ids and every cap a decoder
// enforces. This is the one place these numbers live; docs/protocol.md restates each of them.
// Changing any value here changes the wire format: bump kProtocolMajor (or kProtocolMinor
// for a compatible addition) and regenerate the golden vectors under tests/golden/wire/.
// Pure constants: no I/O.
#pragma once

#include <cstddef>
#include <cstdint>

namespace loam::wire {

// "LOAM" read as a little-endian uint32: the first field of every Hello.
inline constexpr uint32_t kHelloMagic = 0x4D414F4Cu;
// A peer with a different major version cannot parse our messages; minor versions only add
// optional behaviour negotiated in Hello/Welcome, never change a layout.
// 6.0: StampImageListRequest / StampImageList (the server's registered stamp images, for a
// tool panel); Stats ends with the byte budget the server streams to the asking client.
// 5.0: Welcome names the base the initial terrain is (its TileBase identity; 0: none a client
// can rebuild), so a client that can generate that base claims every tile at version 0 and
// only edited tiles travel.
// 4.0: Hello carries a resume key: Deforms resent on a new connection with the same key
// (same client_seq) are answered once and applied once, so a client that reconnects resends
// what was never acknowledged without doubling it.
// 3.0: DeformEvent is compact (varints; tiles as offsets from the stamp's center tile;
// base versions as distances below the sequence) and carries a footprint's contact, so a
// client applies events at every mip of the layer (protocol/replication/event_rule.h).
// Welcome no longer carries a session token; Hello's token is named the access token.
// 2.0: Subscribe entries say whether a version is held (version 0, the initial terrain, can be
// claimed); RegionUpdate patches (the changed samples of a tile over a held version); region
// codec payloads of format 3. 1.1 had added StatsRequest / Stats.
inline constexpr uint16_t kProtocolMajor = 6;
inline constexpr uint16_t kProtocolMinor = 0;

// Frame header: u32 payload length, u16 message type (little-endian), then the payload.
inline constexpr size_t kFrameHeaderBytes = 6;
// A connection's maximum payload unless the server announces another in Welcome. The
// decoder rejects a larger length before it buffers a single payload byte.
inline constexpr uint32_t kDefaultMaxFrameBytes = 1u << 20;
// No connection may configure more than this (keeps every u32 offset sum far from overflow).
inline constexpr uint32_t kAbsoluteMaxFrameBytes = 16u << 20;

enum class MessageType : uint16_t {
  kHello = 1,
  kWelcome = 2,
  kError = 3,
  kPing = 4,
  kPong = 5,
  kBye = 6,
  kSubscribe = 7,
  kUnsubscribe = 8,
  kDeform = 9,
  kDeformAck = 10,
  kDeformEvent = 11,
  kRegionUpdate = 12,
  kTileHashes = 13,
  kStampImageRequest = 14,
  kStampImageResponse = 15,
  kStatsRequest = 16,           // since 1.1
  kStats = 17,                  // since 1.1
  kStampImageListRequest = 18,  // since 6.0
  kStampImageList = 19,         // since 6.0
};
inline constexpr uint16_t kFirstMessageType = 1;
inline constexpr uint16_t kLastMessageType = 19;
const char* to_string(MessageType type);

// --- Caps (a decoder never loops or allocates past these) ---
inline constexpr size_t kMaxClientNameBytes = 64;             // Hello.client_name (UTF-8, not checked)
inline constexpr size_t kAccessTokenBytes = 16;               // Hello.access_token when present
inline constexpr size_t kMaxErrorTextBytes = 1024;            // Error.text, Bye.text
inline constexpr size_t kMaxFieldNameBytes = 64;              // Error.field, DeformAck.field
inline constexpr uint32_t kMaxSubscribeEntries = 1024;        // per Subscribe / Unsubscribe message
inline constexpr uint32_t kMaxEventTiles = 4096;              // tile versions per DeformEvent
inline constexpr uint32_t kMaxRegionChunkBytes = 256u << 10;  // payload bytes per RegionUpdate
inline constexpr uint32_t kMaxRegionPayloadBytes = 4u << 20;  // a whole region, all chunks
inline constexpr uint32_t kMaxTileHashEntries = 1024;         // per TileHashes message
inline constexpr uint32_t kMaxStampImageSide = 512;           // pixels, either side
inline constexpr uint32_t kMaxStampImageListEntries = 1024;   // per StampImageList message
inline constexpr uint32_t kMaxStampImageBytes = kMaxStampImageSide * kMaxStampImageSide * 2;

}  // namespace loam::wire
