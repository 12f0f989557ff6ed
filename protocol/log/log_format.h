// Deformation log format: segment headers and stamp records, encoded and decoded in memory.
// No file I/O here (log_file.h does that), so the fuzzer and the tests drive exactly the
// code that recovery runs. docs/log-format.md is the byte-level specification.
//
// A log is a chain of segments. Segment 0 starts at the initial terrain; every later segment
// starts at a snapshot, so that snapshot plus the segments after it recover the world. Each
// segment is a header followed by records whose global sequences are consecutive.
//
// Safe on untrusted input: scan_segment() bounds-checks every read, caps every length before
// using it, verifies the XXH3-64 checksum of the header and of every record, and reports the
// byte offset of the first damage; it never throws.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/result.h"
#include "protocol/stamps/stamp.h"
#include "protocol/stamps/stamp_validate.h"

namespace loam::log {

inline constexpr char kSegmentMagic[8] = {'L', 'O', 'A', 'M', 'L', 'O', 'G', '\n'};
// Version 2 adds the stamp limits and the base tick to the segment header, and its world
// hashes cover the world's parameters (World::world_hash); version 1 segments still read,
// their hashes being World::content_hash.
inline constexpr uint16_t kLogFormatVersion = 2;
inline constexpr uint16_t kOldestLogFormatVersion = 1;
inline constexpr uint32_t kMaxHeaderBodyBytes = 16384;
inline constexpr size_t kMaxPathBytes = 4096;          // InitialTerrain::dem_path
inline constexpr size_t kMaxImportParamsBytes = 4096;  // InitialTerrain::import_params
// Records: [u32 body length][body][u64 XXH3-64 of length and body]. Each record kind has
// one exact body length; any other length is damage (a new kind adds its length here).
inline constexpr size_t kRecordOverheadBytes = 12;
inline constexpr uint32_t kStampRecordBodyBytes = 75;  // kind + seq + tick + client + stamp

// Where replay finds the terrain a log starts from.
enum class InitialSource : uint8_t {
  kSnapshot = 0,   // snapshot_id names a snapshot file
  kDem = 1,        // dem_path + import_params (an opaque string the importer understands)
  kGenerated = 2,  // the embedded default terrain or a flat fill, described by import_params
};
inline constexpr uint32_t kInitialSourceCount = 3;

struct InitialTerrain {
  uint64_t world_hash = 0;  // World::world_hash() of the initial terrain: replay checks it
  InitialSource source = InitialSource::kGenerated;
  uint64_t snapshot_id = 0;   // kSnapshot
  std::string dem_path;       // kDem, <= kMaxPathBytes
  std::string import_params;  // kDem / kGenerated, <= kMaxImportParamsBytes
  friend bool operator==(const InitialTerrain&, const InitialTerrain&) = default;
};

struct SegmentHeader {
  uint16_t format_version = kLogFormatVersion;
  WorldParams world;
  InitialTerrain initial;
  uint64_t created_unix_us = 0;
  uint32_t segment_index = 0;
  // The state this segment continues from: the world after base_seq. Segment 0 has
  // base_seq 0, base_snapshot_id 0 and base_world_hash == initial.world_hash.
  uint64_t base_seq = 0;
  uint64_t base_snapshot_id = 0;
  uint64_t base_world_hash = 0;
  // Checksum field of the previous segment's header (0 for segment 0): the chain link.
  uint64_t prev_header_checksum = 0;
  // Version 2. The limits every record of this segment was admitted and applied under: what a
  // logged stamp means must not depend on the options of the process that reads it. A
  // version 1 segment recorded none (has_limits false: readers use their own).
  bool has_limits = true;
  StampLimits limits;
  // The tick of the state this segment continues from: records' ticks never go below it, so
  // ticks rise across the whole log and a restarted server continues them.
  uint64_t base_tick = 0;
  // True when the hashes above are World::world_hash (covering the world's parameters);
  // false in version 1 (World::content_hash).
  bool hashes_cover_params() const { return format_version >= 2; }
  friend bool operator==(const SegmentHeader&, const SegmentHeader&) = default;
};

enum class RecordKind : uint8_t { kStamp = 1 };

struct LogRecord {
  uint64_t global_seq = 0;
  uint64_t tick = 0;  // server tick that applied it
  uint32_t client_id = 0;
  QuantizedStamp stamp;
  friend bool operator==(const LogRecord&, const LogRecord&) = default;
};

// Appends the encoded header (magic, length, body, checksum); returns the header checksum.
Result<uint64_t> append_segment_header(std::vector<uint8_t>& out, const SegmentHeader& h);
// Appends one encoded record.
Status append_record(std::vector<uint8_t>& out, const LogRecord& r);

struct DecodedHeader {
  SegmentHeader header;
  uint64_t checksum = 0;  // what the next segment's prev_header_checksum must equal
  size_t bytes = 0;       // encoded size: records start here
};
Result<DecodedHeader> decode_segment_header(std::span<const uint8_t> bytes);

// Decodes the record at `offset`; on success sets *next_offset past it.
Result<LogRecord> decode_record(std::span<const uint8_t> bytes, size_t offset, size_t* next_offset);

enum class TailState : uint8_t {
  kClean,    // every byte belongs to a good record
  kTorn,     // the last record is incomplete (crash during append): truncating loses only it
  kCorrupt,  // a record fails its checksum or has an impossible length
};
const char* to_string(TailState s);

struct SegmentScan {
  DecodedHeader header;
  std::vector<LogRecord> records;
  size_t good_bytes = 0;  // offset just past the last good record
  TailState tail = TailState::kClean;
  std::optional<Error> tail_error;  // the damage, its message naming the byte offset
  size_t damage_offset = 0;         // byte offset of the first damaged record
  // True when the damage is a torn append: the file ends inside the final record, or zeros
  // run to the end (a file system extended the file before the data landed). Truncating to
  // good_bytes then loses only a record that was never acknowledged. False for anything else,
  // a complete record with a bad checksum at the end included: that is media damage to a
  // record that may have been acknowledged, and an operator must decide
  // (`loam-server log repair`).
  bool recoverable = true;
  uint64_t last_tick = 0;  // of the last good record (base_tick when none)

  uint64_t last_seq() const { return records.empty() ? header.header.base_seq : records.back().global_seq; }
};

// Scans a whole segment. A bad header, or a record sequence that is not base_seq+1,
// base_seq+2, ... (gap or disorder), or ticks that go backwards, is an Error (with the
// offset in its message); damage to records is reported in SegmentScan::tail.
Result<SegmentScan> scan_segment(std::span<const uint8_t> bytes);

// Checks that `next` continues `prev` (index, world, initial terrain, base_seq == last seq
// of prev, prev_header_checksum). The error names the header field that breaks the chain.
Status check_chain(const SegmentScan& prev, const SegmentHeader& next);

}  // namespace loam::log
