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
  // Like create(), but writes the file beside `path` and renames it over `path`: replaces a
  // segment that holds no records (a session that has not stamped yet, restarted with other
  // limits). The caller checks that it holds none.
  static Result<LogWriter> create_replacing(const std::string& path, const SegmentHeader& header);
  // Reopens an existing segment to append after its last record. Fails if its tail is not
  // clean: run recover_segment() first.
  static Result<LogWriter> open_append(const std::string& path);
  // Reopens a segment after a failed sync(): cuts it back to `durable_bytes` (what the last
  // successful sync made durable; a failed write may have left part of a batch after it),
  // makes that durable and opens it for appending. Errors when the file is shorter than
  // `durable_bytes` or its records do not end at `expected_last_seq`.
  static Result<LogWriter> reopen_after_failure(const std::string& path, uint64_t durable_bytes,
                                                uint64_t expected_last_seq);

  LogWriter(LogWriter&& other) noexcept;
  LogWriter& operator=(LogWriter&& other) noexcept;
  LogWriter(const LogWriter&) = delete;
  LogWriter& operator=(const LogWriter&) = delete;
  ~LogWriter();  // closes without syncing: unsynced records are not durable

  // Buffers one record; its sequence must be next_seq() and its tick not before the last.
  Status append(const LogRecord& r);
  // Writes every buffered record and fdatasyncs: the durability point. On failure (a full
  // disk, an I/O error) the records buffered since the last successful sync are not durable:
  // the file is cut back to durable_bytes() where possible and the writer closes (after a
  // failed fsync the page cache cannot be trusted); reopen it with reopen_after_failure().
  Status sync();
  bool is_open() const { return fd_ >= 0; }
  const std::string& path() const { return path_; }
  uint64_t last_tick() const { return last_tick_; }
  // Bytes made durable by the last successful sync (or create/open).
  uint64_t durable_bytes() const { return durable_bytes_; }

  uint64_t next_seq() const { return next_seq_; }
  uint64_t header_checksum() const { return header_checksum_; }
  const SegmentHeader& header() const { return header_; }
  size_t pending_bytes() const { return pending_.size(); }
  uint64_t file_bytes() const { return file_bytes_; }  // durable or written bytes so far

 private:
  LogWriter() = default;
  void fail_back_to_durable();
  int fd_ = -1;
  std::string path_;
  SegmentHeader header_;
  uint64_t header_checksum_ = 0;
  uint64_t next_seq_ = 1;
  uint64_t last_tick_ = 0;
  uint64_t file_bytes_ = 0;
  uint64_t durable_bytes_ = 0;
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

// Cuts a segment file to `length` bytes and fsyncs it (recover_segment for a torn tail;
// `loam-server log repair` when an operator drops a damaged record).
Status truncate_segment(const std::string& path, uint64_t length);

// Scans segment files in order and checks that each chains to the one before it; only the
// last may have a damaged tail (reported in its scan, not repaired).
Result<std::vector<SegmentScan>> read_log(const std::vector<std::string>& paths);

}  // namespace loam::log
