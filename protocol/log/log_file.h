// Deformation log files: an append-only segment writer with an explicit durability call, and
// readers that scan, recover and chain segments. POSIX file I/O (open/write/fdatasync/
// ftruncate); the byte format is log_format.h. Safe on untrusted files: everything read goes
// through scan_segment(). Errors are Results (kIo names the path); nothing throws.
//
// Group commit: the server appends every record of a tick, then calls sync() once; only
// after sync() returns OK may it acknowledge those stamps.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "protocol/log/log_format.h"
#include "protocol/result.h"

namespace loam::log {

// "segment-00000003.loamlog": the name the server gives segment `index` in its log folder.
std::string segment_file_name(uint32_t index);

class LogWriter {
 public:
  // Creates a new segment file (fails if it exists), writes the header and makes it durable
  // (file and directory fsync). The first record must have sequence header.base_seq + 1.
  static Result<LogWriter> create(const std::string& path, const SegmentHeader& header);
  // Reopens an existing segment to append after its last record. Fails if its tail is not
  // clean: run recover_segment() first.
  static Result<LogWriter> open_append(const std::string& path);

  LogWriter(LogWriter&& other) noexcept;
  LogWriter& operator=(LogWriter&& other) noexcept;
  LogWriter(const LogWriter&) = delete;
  LogWriter& operator=(const LogWriter&) = delete;
  ~LogWriter();  // closes without syncing: unsynced records are not durable

  // Buffers one record; its sequence must be next_seq() and its tick not before the last.
  Status append(const LogRecord& r);
  // Writes every buffered record and fdatasyncs: the durability point.
  Status sync();

  uint64_t next_seq() const { return next_seq_; }
  uint64_t header_checksum() const { return header_checksum_; }
  const SegmentHeader& header() const { return header_; }
  size_t pending_bytes() const { return pending_.size(); }
  uint64_t file_bytes() const { return file_bytes_; }  // durable or written bytes so far

 private:
  LogWriter() = default;
  int fd_ = -1;
  std::string path_;
  SegmentHeader header_;
  uint64_t header_checksum_ = 0;
  uint64_t next_seq_ = 1;
  uint64_t last_tick_ = 0;
  uint64_t file_bytes_ = 0;
  std::vector<uint8_t> pending_;
};

// Reads a whole file (up to max_bytes; larger is kOversize).
Result<std::vector<uint8_t>> read_file(const std::string& path, uint64_t max_bytes = uint64_t(1) << 34);

// Reads and scans one segment file.
Result<SegmentScan> read_segment(const std::string& path);

struct Recovery {
  SegmentScan scan;            // after recovery (tail clean)
  uint64_t removed_bytes = 0;  // 0 when the tail was already clean
  uint64_t truncated_at = 0;   // byte offset of the cut (the first damaged record)
  std::string damage;          // what was found, for the server's log
};
// Scans a segment; if the tail is torn (or the damage is confined to the final record),
// truncates the file to the last good record and fsyncs. Damage with data after it is a
// kCorrupt Error naming the byte offset, and the file is left untouched.
Result<Recovery> recover_segment(const std::string& path);

// Scans segment files in order and checks that each chains to the one before it; only the
// last may have a damaged tail (reported in its scan, not repaired).
Result<std::vector<SegmentScan>> read_log(const std::vector<std::string>& paths);

}  // namespace loam::log
