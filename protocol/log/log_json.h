// Human views of a deformation log: JSON lines (one object per header and record) and a
// summary. Works on a SegmentScan, so it never sees unchecked bytes. 64-bit hashes and ids
// are written as 16-digit hex strings (JSON numbers lose bits above 2^53); sequences, ticks
// and stamp integers as numbers. docs/log-format.md lists the keys.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "protocol/layer.h"
#include "protocol/log/log_format.h"

namespace loam::log {

std::string header_to_json(const DecodedHeader& h);
std::string record_to_json(const LogRecord& r);
// Header line, one line per record, and a final {"type":"tail",...} line if damaged.
std::string dump_jsonl(const SegmentScan& scan);

struct LogSummary {
  uint32_t segments = 0;
  uint64_t records = 0;
  uint64_t first_seq = 0;  // 0 when there are no records
  uint64_t last_seq = 0;
  uint64_t first_tick = 0;
  uint64_t last_tick = 0;
  std::array<uint64_t, kStampKindCount> per_kind{};
  PerLayer<uint64_t> per_layer;
  uint64_t distinct_clients = 0;
  uint64_t created_unix_us = 0;  // of the first segment
  uint64_t damaged_segments = 0;
};
// Summarizes consecutive segments (e.g. read_log's result, or a single scan).
LogSummary summarize(std::span<const SegmentScan> scans);
std::string summary_to_json(const LogSummary& s);
std::string summary_to_text(const LogSummary& s);

}  // namespace loam::log
