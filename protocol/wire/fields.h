// Serialize functions for the compound fields shared by wire messages and log records:
// TileCoord, a tile-local rect, WorldParams and QuantizedStamp. Each runs against
// WriteStream, ReadStream and MeasureStream (byte_stream.h) and checks ranges both ways.
// Safe on untrusted input. docs/protocol.md ("Common fields") gives the byte layouts.
#pragma once

#include "protocol/geometry.h"
#include "protocol/layer.h"
#include "protocol/stamps/stamp.h"
#include "protocol/wire/byte_stream.h"

namespace loam::wire {

// 10 bytes: u8 layer, u8 mip, i32 tx, i32 ty. The detail layer exists at mip 0 only.
inline constexpr size_t kTileCoordBytes = 10;
template <typename S>
Status serialize_tile(S& s, TileCoord& c) {
  LOAM_TRY(serialize_enum(s, c.layer, uint32_t(kLayerCount), "tile.layer"));
  LOAM_TRY(serialize_range<uint8_t>(s, c.mip, 0, kMaxMips - 1, "tile.mip"));
  if (!layer_has_mip(c.layer, c.mip)) {
    return make_error(ErrorCode::kInvalidArgument, "tile.mip", "the detail layer has mip 0 only");
  }
  LOAM_TRY(s.bits(c.tx, "tile.tx"));
  LOAM_TRY(s.bits(c.ty, "tile.ty"));
  return {};
}

// 8 bytes: u16 x0, y0, x1, y1 in tile-local samples; 0 <= x0 < x1 <= kTileSize (same for y).
inline constexpr size_t kTileRectBytes = 8;
template <typename S>
Status serialize_tile_rect(S& s, RectI& r) {
  const auto in_tile = [](int64_t v) { return v >= 0 && v <= kTileSize; };
  if constexpr (!S::kReading) {
    if (!in_tile(r.x0) || !in_tile(r.y0) || !in_tile(r.x1) || !in_tile(r.y1) || r.empty()) {
      return make_error(ErrorCode::kInvalidArgument, "rect", "must be non-empty and inside the tile");
    }
  }
  uint16_t v[4] = {uint16_t(r.x0), uint16_t(r.y0), uint16_t(r.x1), uint16_t(r.y1)};
  LOAM_TRY(s.bits(v[0], "rect.x0"));
  LOAM_TRY(s.bits(v[1], "rect.y0"));
  LOAM_TRY(s.bits(v[2], "rect.x1"));
  LOAM_TRY(s.bits(v[3], "rect.y1"));
  if (v[2] > kTileSize || v[3] > kTileSize) {
    return make_error(ErrorCode::kInvalidArgument, "rect.x1", "beyond the tile edge");
  }
  if (v[0] >= v[2]) return make_error(ErrorCode::kInvalidArgument, "rect.x0", "x0 must be < x1");
  if (v[1] >= v[3]) return make_error(ErrorCode::kInvalidArgument, "rect.y0", "y0 must be < y1");
  if constexpr (S::kReading) r = RectI{v[0], v[1], v[2], v[3]};
  return {};
}

// 52 bytes; the decoded parameters must pass WorldParams::validate().
inline constexpr size_t kWorldParamsBytes = 52;
template <typename S>
Status serialize_world_params(S& s, WorldParams& p) {
  LOAM_TRY(s.f64(p.meters_per_sample, "world.meters_per_sample"));
  LOAM_TRY(s.f64(p.height_offset, "world.height_offset"));
  LOAM_TRY(s.f64(p.meters_per_unit, "world.meters_per_unit"));
  LOAM_TRY(s.bits(p.detail_factor, "world.detail_factor"));
  LOAM_TRY(s.f64(p.detail_meters_per_unit, "world.detail_meters_per_unit"));
  LOAM_TRY(s.bits(p.origin_tile_x, "world.origin_tile_x"));
  LOAM_TRY(s.bits(p.origin_tile_y, "world.origin_tile_y"));
  LOAM_TRY(s.bits(p.tiles_x, "world.tiles_x"));
  LOAM_TRY(s.bits(p.tiles_y, "world.tiles_y"));
  if (Status st = p.validate(); !st.ok()) {
    Error e = st.error();
    e.field = "world." + e.field;
    return e;
  }
  return {};
}

// 54 bytes, field by field in declaration order. Enumerations and flags are checked here;
// the stamp's semantic ranges (radius > 0, steps cap, ...) are the stamp validator's job.
inline constexpr size_t kStampBytes = 54;
template <typename S>
Status serialize_stamp(S& s, QuantizedStamp& q) {
  LOAM_TRY(serialize_enum(s, q.kind, kStampKindCount, "stamp.kind"));
  LOAM_TRY(serialize_enum(s, q.layer, 2, "stamp.layer"));
  LOAM_TRY(serialize_enum(s, q.blend, kBlendModeCount, "stamp.blend"));
  LOAM_TRY(s.bits(q.flags, "stamp.flags"));
  if ((q.flags & ~kStampKnownFlags) != 0) {
    return make_error(ErrorCode::kBadEnum, "stamp.flags", "unknown flag bits " + std::to_string(q.flags));
  }
  LOAM_TRY(s.bits(q.center_x, "stamp.center_x"));
  LOAM_TRY(s.bits(q.center_y, "stamp.center_y"));
  LOAM_TRY(s.bits(q.radius, "stamp.radius"));
  LOAM_TRY(s.bits(q.rotation, "stamp.rotation"));
  LOAM_TRY(s.bits(q.intensity, "stamp.intensity"));
  LOAM_TRY(s.bits(q.target, "stamp.target"));
  LOAM_TRY(s.bits(q.shape, "stamp.shape"));
  LOAM_TRY(s.bits(q.damping, "stamp.damping"));
  LOAM_TRY(s.bits(q.speed, "stamp.speed"));
  LOAM_TRY(s.bits(q.steps, "stamp.steps"));
  LOAM_TRY(s.bits(q.seed, "stamp.seed"));
  LOAM_TRY(s.bits(q.texture_id, "stamp.texture_id"));
  return {};
}

// The compact stamp of a DeformEvent (protocol 3), 8..40 bytes, typically 12..16:
//   u8 head: bits 0-2 kind, bit 3 layer, bits 4-5 blend, bit 6 volume-conserving, bit 7 zero;
//   zigzag varint center_x, center_y; varint radius;
//   varint presence mask (bit i: field i below is non-zero and follows, in this order):
//   rotation, intensity (zigzag), target (zigzag), shape, damping, speed, steps, seed,
//   texture_id. Absent fields are zero. Enumerations and flags are checked as in
//   serialize_stamp; semantic ranges stay the validator's job.
template <typename S>
Status serialize_stamp_compact(S& s, QuantizedStamp& q) {
  uint8_t head = uint8_t(uint8_t(q.kind) | uint8_t(uint8_t(q.layer) << 3) | uint8_t(uint8_t(q.blend) << 4) |
                         ((q.flags & kStampFlagVolumeConserving) ? 0x40 : 0));
  if constexpr (!S::kReading) {
    if (uint8_t(q.kind) >= kStampKindCount || uint8_t(q.blend) >= kBlendModeCount || uint8_t(q.layer) > 1)
      return make_error(ErrorCode::kBadEnum, "stamp.head", "kind, layer or blend out of range");
    if ((q.flags & ~kStampKnownFlags) != 0)
      return make_error(ErrorCode::kBadEnum, "stamp.flags", "unknown flag bits " + std::to_string(q.flags));
  }
  LOAM_TRY(s.bits(head, "stamp.head"));
  if constexpr (S::kReading) {
    if ((head & 0x80) != 0) return make_error(ErrorCode::kBadEnum, "stamp.head", "reserved bit 7 set");
    if ((head & 7) >= kStampKindCount) return bad_enum_error("stamp.kind", head & 7, kStampKindCount);
    q.kind = StampKind(head & 7);
    q.layer = Layer((head >> 3) & 1);
    q.blend = BlendMode((head >> 4) & 3);
    q.flags = (head & 0x40) ? kStampFlagVolumeConserving : 0;
  }
  LOAM_TRY(serialize_svarint(s, q.center_x, "stamp.center_x"));
  LOAM_TRY(serialize_svarint(s, q.center_y, "stamp.center_y"));
  LOAM_TRY(serialize_uvarint(s, q.radius, "stamp.radius"));
  uint32_t mask = (q.rotation ? 1u : 0) | (q.intensity ? 2u : 0) | (q.target ? 4u : 0) | (q.shape ? 8u : 0) |
                  (q.damping ? 16u : 0) | (q.speed ? 32u : 0) | (q.steps ? 64u : 0) | (q.seed ? 128u : 0) |
                  (q.texture_id ? 256u : 0);
  LOAM_TRY(serialize_uvarint<uint32_t>(s, mask, "stamp.fields", 0, 511));
  // One optional field: present (and then non-zero: one encoding per stamp) or zero.
  const auto field = [&](uint32_t bit, auto& v, const char* name) -> Status {
    if (!(mask & bit)) {
      if constexpr (S::kReading) v = 0;
      return {};
    }
    if constexpr (std::is_signed_v<std::remove_reference_t<decltype(v)>>) {
      LOAM_TRY(serialize_svarint(s, v, name));
    } else {
      LOAM_TRY(serialize_uvarint(s, v, name));
    }
    if (v == 0) return make_error(ErrorCode::kCorrupt, name, "listed as present but zero");
    return {};
  };
  LOAM_TRY(field(1u, q.rotation, "stamp.rotation"));
  LOAM_TRY(field(2u, q.intensity, "stamp.intensity"));
  LOAM_TRY(field(4u, q.target, "stamp.target"));
  LOAM_TRY(field(8u, q.shape, "stamp.shape"));
  LOAM_TRY(field(16u, q.damping, "stamp.damping"));
  LOAM_TRY(field(32u, q.speed, "stamp.speed"));
  LOAM_TRY(field(64u, q.steps, "stamp.steps"));
  LOAM_TRY(field(128u, q.seed, "stamp.seed"));
  LOAM_TRY(field(256u, q.texture_id, "stamp.texture_id"));
  return {};
}

}  // namespace loam::wire
