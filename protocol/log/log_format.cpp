#include "protocol/log/log_format.h"

#include <xxhash.h>

#include <algorithm>
#include <cstring>

#include "protocol/byte_order.h"
#include "protocol/wire/byte_stream.h"
#include "protocol/wire/fields.h"

namespace loam::log {

const char* to_string(TailState s) {
  switch (s) {
    case TailState::kClean: return "clean";
    case TailState::kTorn: return "torn";
    case TailState::kCorrupt: return "corrupt";
  }
  return "unknown";
}

namespace {

constexpr size_t kHeaderPrefixBytes = sizeof(kSegmentMagic) + 4;  // magic + body length

std::string at(size_t offset) { return "at byte offset " + std::to_string(offset) + ": "; }

template <typename S>
Status serialize_header_body(S& s, SegmentHeader& h) {
  // The version comes first so a future reader can refuse before parsing anything else.
  LOAM_TRY(s.bits(h.format_version, "log.format_version"));
  if (h.format_version < kOldestLogFormatVersion || h.format_version > kLogFormatVersion) {
    return make_error(ErrorCode::kUnsupported, "log.format_version",
                      "log format " + std::to_string(h.format_version) + ", this reader knows " +
                          std::to_string(kOldestLogFormatVersion) + ".." + std::to_string(kLogFormatVersion));
  }
  LOAM_TRY(wire::serialize_world_params(s, h.world));
  LOAM_TRY(s.bits(h.initial.world_hash, "log.initial.world_hash"));
  LOAM_TRY(wire::serialize_enum(s, h.initial.source, kInitialSourceCount, "log.initial.source"));
  LOAM_TRY(s.bits(h.initial.snapshot_id, "log.initial.snapshot_id"));
  LOAM_TRY(s.string(h.initial.dem_path, kMaxPathBytes, "log.initial.dem_path"));
  LOAM_TRY(s.string(h.initial.import_params, kMaxImportParamsBytes, "log.initial.import_params"));
  LOAM_TRY(s.bits(h.created_unix_us, "log.created_unix_us"));
  LOAM_TRY(s.bits(h.segment_index, "log.segment_index"));
  LOAM_TRY(s.bits(h.base_seq, "log.base_seq"));
  LOAM_TRY(s.bits(h.base_snapshot_id, "log.base_snapshot_id"));
  LOAM_TRY(s.bits(h.base_world_hash, "log.base_world_hash"));
  LOAM_TRY(s.bits(h.prev_header_checksum, "log.prev_header_checksum"));
  if (h.format_version >= 2) {
    h.has_limits = true;
    LOAM_TRY(s.f64(h.limits.max_radius_samples, "log.limits.max_radius_samples"));
    LOAM_TRY(s.bits(h.limits.max_shockwave_steps, "log.limits.max_shockwave_steps"));
    LOAM_TRY(s.bits(h.limits.max_shockwave_cells, "log.limits.max_shockwave_cells"));
    if (Status st = validate_limits(h.limits); !st.ok()) {
      Error e = st.error();
      e.field = "log." + e.field;
      return e;
    }
    LOAM_TRY(s.bits(h.base_tick, "log.base_tick"));
  } else {
    h.has_limits = false;
    h.limits = {};
    h.base_tick = 0;
  }
  if (h.segment_index == 0) {
    // The first segment starts at the initial terrain and chains to nothing.
    if (h.base_seq != 0) return make_error(ErrorCode::kCorrupt, "log.base_seq", "must be 0 in segment 0");
    if (h.base_snapshot_id != 0 || h.prev_header_checksum != 0) {
      return make_error(ErrorCode::kCorrupt, "log.prev_header_checksum", "segment 0 chains to nothing");
    }
    if (h.base_world_hash != h.initial.world_hash) {
      return make_error(ErrorCode::kCorrupt, "log.base_world_hash",
                        "segment 0 must start from the initial terrain's hash");
    }
  } else if (h.base_snapshot_id == 0) {
    return make_error(ErrorCode::kCorrupt, "log.base_snapshot_id", "a later segment starts at a snapshot");
  }
  return {};
}

template <typename S>
Status serialize_record_body(S& s, LogRecord& r) {
  auto kind = RecordKind::kStamp;
  uint8_t raw = static_cast<uint8_t>(kind);
  LOAM_TRY(s.bits(raw, "record.kind"));
  if (raw != static_cast<uint8_t>(RecordKind::kStamp)) {
    return make_error(ErrorCode::kUnknownType, "record.kind", "unknown record kind " + std::to_string(raw));
  }
  LOAM_TRY(s.bits(r.global_seq, "record.global_seq"));
  LOAM_TRY(s.bits(r.tick, "record.tick"));
  LOAM_TRY(s.bits(r.client_id, "record.client_id"));
  LOAM_TRY(wire::serialize_stamp(s, r.stamp));
  return {};
}

uint64_t checksum(const uint8_t* p, size_t n) { return XXH3_64bits(p, n); }

bool zeros_to_end(std::span<const uint8_t> bytes, size_t offset) {
  return std::all_of(bytes.begin() + static_cast<ptrdiff_t>(offset), bytes.end(),
                     [](uint8_t b) { return b == 0; });
}

// One record at `offset`, classified the way recovery needs: good, torn (ends early), or
// corrupt. `recoverable` says whether the damage is confined to the end of the segment.
struct RecordRead {
  TailState state = TailState::kClean;
  LogRecord record;
  size_t next = 0;
  std::optional<Error> error;
  bool recoverable = true;
};

RecordRead read_record(std::span<const uint8_t> bytes, size_t offset) {
  RecordRead rr;
  const size_t remaining = bytes.size() - offset;
  if (remaining < 4) {
    rr.state = TailState::kTorn;
    rr.error = make_error(ErrorCode::kTruncated, "record.length", at(offset) + "record length cut short");
    return rr;
  }
  const uint32_t len = load_le<uint32_t>(bytes.data() + offset);
  // Every record kind has one exact body length, so a damaged length field is caught here
  // rather than sending the scan to a wrong offset or mistaking mid-file damage for a torn tail.
  if (len != kStampRecordBodyBytes) {
    // A file system may extend a file before the data lands: zeros to the end are a torn
    // append, not corruption. Anything else is a damaged length we must not follow.
    if (zeros_to_end(bytes, offset)) {
      rr.state = TailState::kTorn;
      rr.error = make_error(ErrorCode::kTruncated, "record.length", at(offset) + "zero-filled tail");
      return rr;
    }
    rr.state = TailState::kCorrupt;
    // A torn append is short: a damaged length with a whole record's bytes or more after it
    // is damage to written data, never truncated by itself.
    rr.recoverable = remaining < kRecordOverheadBytes + kStampRecordBodyBytes;
    if (rr.recoverable) {
      rr.state = TailState::kTorn;
      rr.error = make_error(ErrorCode::kTruncated, "record.length",
                            at(offset) + "record cut short (" + std::to_string(remaining) + " bytes)");
      return rr;
    }
    rr.error = make_error(ErrorCode::kCorrupt, "record.length",
                          at(offset) + "impossible record length " + std::to_string(len));
    return rr;
  }
  const size_t total = 4 + size_t(len) + 8;
  if (remaining < total) {
    rr.state = TailState::kTorn;
    rr.error = make_error(ErrorCode::kTruncated, "record",
                          at(offset) + "record of " + std::to_string(total) + " bytes, only " +
                              std::to_string(remaining) + " left");
    return rr;
  }
  const uint64_t stored = load_le<uint64_t>(bytes.data() + offset + 4 + len);
  const bool at_end = offset + total == bytes.size();
  if (stored != checksum(bytes.data() + offset, 4 + size_t(len))) {
    // A complete record that fails its checksum is media damage, not a torn append (a torn
    // append is short), even at the very end: it may have been acknowledged after its
    // fdatasync, so it is never dropped silently. A zero-filled remainder is still torn.
    if (at_end && zeros_to_end(bytes, offset + 4)) {
      rr.state = TailState::kTorn;
      rr.error = make_error(ErrorCode::kTruncated, "record", at(offset) + "zero-filled final record");
      return rr;
    }
    rr.state = TailState::kCorrupt;
    rr.recoverable = false;
    rr.error =
        make_error(ErrorCode::kCorrupt, "record.checksum",
                   at(offset) + (at_end ? "complete final record fails its checksum (media damage, not a "
                                          "torn append)"
                                        : "record checksum mismatch"));
    return rr;
  }
  wire::ReadStream s(bytes.subspan(offset + 4, len));
  Status st = serialize_record_body(s, rr.record);
  if (st.ok()) st = s.expect_end("record");
  if (!st.ok()) {
    // A checksummed record that does not decode was written by a broken or newer writer.
    rr.state = TailState::kCorrupt;
    rr.recoverable = false;
    (void)at_end;
    Error e = st.error();
    e.message = at(offset) + e.message;
    rr.error = e;
    return rr;
  }
  rr.next = offset + total;
  return rr;
}

}  // namespace

Result<uint64_t> append_segment_header(std::vector<uint8_t>& out, const SegmentHeader& h) {
  std::vector<uint8_t> body;
  wire::WriteStream s(body);
  LOAM_TRY(serialize_header_body(s, const_cast<SegmentHeader&>(h)));  // write path: read-only
  if (body.size() > kMaxHeaderBodyBytes) {
    return wire::oversize_error("log.header_length", body.size(), kMaxHeaderBodyBytes);
  }
  const size_t start = out.size();
  out.insert(out.end(), kSegmentMagic, kSegmentMagic + sizeof(kSegmentMagic));
  out.resize(out.size() + 4);
  store_le<uint32_t>(out.data() + start + sizeof(kSegmentMagic), static_cast<uint32_t>(body.size()));
  out.insert(out.end(), body.begin(), body.end());
  const uint64_t sum = checksum(out.data() + start, out.size() - start);
  out.resize(out.size() + 8);
  store_le<uint64_t>(out.data() + out.size() - 8, sum);
  return sum;
}

Status append_record(std::vector<uint8_t>& out, const LogRecord& r) {
  std::vector<uint8_t> body;
  wire::WriteStream s(body);
  LOAM_TRY(serialize_record_body(s, const_cast<LogRecord&>(r)));  // write path: read-only
  const size_t start = out.size();
  out.resize(start + 4);
  store_le<uint32_t>(out.data() + start, static_cast<uint32_t>(body.size()));
  out.insert(out.end(), body.begin(), body.end());
  const uint64_t sum = checksum(out.data() + start, out.size() - start);
  out.resize(out.size() + 8);
  store_le<uint64_t>(out.data() + out.size() - 8, sum);
  return {};
}

Result<DecodedHeader> decode_segment_header(std::span<const uint8_t> bytes) {
  if (bytes.size() < kHeaderPrefixBytes) {
    return wire::truncated_error("log.magic", kHeaderPrefixBytes, 0, bytes.size());
  }
  if (std::memcmp(bytes.data(), kSegmentMagic, sizeof(kSegmentMagic)) != 0) {
    return make_error(ErrorCode::kCorrupt, "log.magic", "not a Loam log segment");
  }
  const uint32_t len = load_le<uint32_t>(bytes.data() + sizeof(kSegmentMagic));
  if (len > kMaxHeaderBodyBytes) return wire::oversize_error("log.header_length", len, kMaxHeaderBodyBytes);
  const size_t total = kHeaderPrefixBytes + size_t(len) + 8;
  if (bytes.size() < total) return wire::truncated_error("log.header", total, 0, bytes.size());
  DecodedHeader d;
  d.checksum = load_le<uint64_t>(bytes.data() + kHeaderPrefixBytes + len);
  if (d.checksum != checksum(bytes.data(), kHeaderPrefixBytes + len)) {
    return make_error(ErrorCode::kCorrupt, "log.header_checksum", at(0) + "segment header checksum mismatch");
  }
  wire::ReadStream s(bytes.subspan(kHeaderPrefixBytes, len));
  LOAM_TRY(serialize_header_body(s, d.header));
  LOAM_TRY(s.expect_end("log.header"));
  d.bytes = total;
  return d;
}

Result<LogRecord> decode_record(std::span<const uint8_t> bytes, size_t offset, size_t* next_offset) {
  if (offset > bytes.size()) return wire::truncated_error("record", 4, offset, 0);
  RecordRead rr = read_record(bytes, offset);
  if (rr.error) return *rr.error;
  if (next_offset) *next_offset = rr.next;
  return rr.record;
}

Result<SegmentScan> scan_segment(std::span<const uint8_t> bytes) {
  Result<DecodedHeader> h = decode_segment_header(bytes);
  if (!h.ok()) return h.error();
  SegmentScan scan;
  scan.header = std::move(*h);
  size_t offset = scan.header.bytes;
  scan.good_bytes = offset;
  uint64_t expected = scan.header.header.base_seq + 1;
  uint64_t last_tick = scan.header.header.base_tick;
  scan.last_tick = last_tick;
  while (offset < bytes.size()) {
    RecordRead rr = read_record(bytes, offset);
    if (rr.error) {
      scan.tail = rr.state;
      scan.tail_error = rr.error;
      scan.damage_offset = offset;
      scan.recoverable = rr.recoverable;
      break;
    }
    if (rr.record.global_seq != expected) {
      return make_error(ErrorCode::kCorrupt, "record.global_seq",
                        at(offset) + "expected sequence " + std::to_string(expected) + ", found " +
                            std::to_string(rr.record.global_seq) +
                            (rr.record.global_seq > expected ? " (gap)" : " (disorder)"));
    }
    if (rr.record.tick < last_tick) {
      return make_error(
          ErrorCode::kCorrupt, "record.tick",
          at(offset) + "tick " + std::to_string(rr.record.tick) + " after tick " + std::to_string(last_tick));
    }
    last_tick = rr.record.tick;
    scan.last_tick = last_tick;
    ++expected;
    // Bounded by the file size: each record consumed at least kRecordOverheadBytes + 1.
    scan.records.push_back(rr.record);
    offset = rr.next;
    scan.good_bytes = offset;
  }
  return scan;
}

Status check_chain(const SegmentScan& prev, const SegmentHeader& next) {
  const SegmentHeader& p = prev.header.header;
  if (prev.tail != TailState::kClean) {
    return make_error(ErrorCode::kCorrupt, "log.tail",
                      "segment " + std::to_string(p.segment_index) + " has a " + to_string(prev.tail) +
                          " tail but another segment follows it");
  }
  if (next.segment_index != p.segment_index + 1) {
    return make_error(ErrorCode::kCorrupt, "log.segment_index",
                      "segment " + std::to_string(next.segment_index) + " follows segment " +
                          std::to_string(p.segment_index));
  }
  if (!(next.world == p.world)) {
    return make_error(ErrorCode::kCorrupt, "log.world", "world parameters differ from the previous segment");
  }
  // Version 1 hashed the content only: across a version change the hashes differ in meaning.
  log::InitialTerrain a = next.initial, b = p.initial;
  if (next.format_version != p.format_version) a.world_hash = b.world_hash = 0;
  if (!(a == b)) {
    return make_error(ErrorCode::kCorrupt, "log.initial",
                      "initial terrain differs from the previous segment");
  }
  if (next.base_seq != prev.last_seq()) {
    return make_error(ErrorCode::kCorrupt, "log.base_seq",
                      "segment starts after sequence " + std::to_string(next.base_seq) +
                          " but the previous segment ends at " + std::to_string(prev.last_seq()));
  }
  if (next.format_version < p.format_version) {
    return make_error(ErrorCode::kCorrupt, "log.format_version",
                      "segment of format " + std::to_string(next.format_version) + " follows one of format " +
                          std::to_string(p.format_version));
  }
  if (next.base_tick < prev.last_tick) {
    return make_error(ErrorCode::kCorrupt, "log.base_tick",
                      "segment starts at tick " + std::to_string(next.base_tick) +
                          " but the previous segment ends at tick " + std::to_string(prev.last_tick));
  }
  if (next.prev_header_checksum != prev.header.checksum) {
    return make_error(ErrorCode::kCorrupt, "log.prev_header_checksum",
                      "does not match the previous segment's header checksum");
  }
  return {};
}

}  // namespace loam::log
