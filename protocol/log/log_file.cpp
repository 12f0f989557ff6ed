#include "protocol/log/log_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <utility>

#include "protocol/file_io.h"

namespace loam::log {

namespace {

Error io_error(const std::string& path, const char* what) {
  return make_error(ErrorCode::kIo, path, std::string(what) + ": " + std::strerror(errno));
}

Status write_all(int fd, const uint8_t* p, size_t n, const std::string& path) {
  return write_exact(fd, std::span<const uint8_t>(p, n), path);
}

// A new file's directory entry is durable only once the directory itself is synced.
Status sync_parent_dir(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return io_error(dir, "open directory");
  const int rc = ::fsync(fd);
  ::close(fd);
  if (rc != 0) return io_error(dir, "fsync directory");
  return {};
}

}  // namespace

std::string segment_file_name(uint32_t index) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "segment-%08u.loamlog", index);
  return buf;
}

namespace {

// Writes a new segment file holding only `bytes` (its header) at `path` and makes it
// durable. A failure (a full disk) removes the partial file: a segment with a torn header
// would stop the next start-up.
Status write_new_segment(int fd, const std::string& path, const std::vector<uint8_t>& bytes) {
  Status st = write_all(fd, bytes.data(), bytes.size(), path);
  if (st.ok() && ::fsync(fd) != 0) st = io_error(path, "fsync");
  if (!st.ok()) ::unlink(path.c_str());
  return st;
}

}  // namespace

Result<LogWriter> LogWriter::create(const std::string& path, const SegmentHeader& header) {
  std::vector<uint8_t> bytes;
  Result<uint64_t> sum = append_segment_header(bytes, header);
  if (!sum.ok()) return sum.error();
  LogWriter w;
  w.fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (w.fd_ < 0) return io_error(path, "create");
  w.path_ = path;
  w.header_ = header;
  w.header_checksum_ = *sum;
  w.next_seq_ = header.base_seq + 1;
  w.last_tick_ = header.base_tick;
  LOAM_TRY(write_new_segment(w.fd_, path, bytes));
  LOAM_TRY(sync_parent_dir(path));
  w.file_bytes_ = w.durable_bytes_ = bytes.size();
  return w;
}

Result<LogWriter> LogWriter::create_replacing(const std::string& path, const SegmentHeader& header) {
  const std::string tmp = path + ".tmp";
  ::unlink(tmp.c_str());  // a leftover of an earlier attempt
  Result<LogWriter> w = create(tmp, header);
  if (!w.ok()) return w.error();
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    Error e = io_error(path, "rename");
    ::unlink(tmp.c_str());
    return e;
  }
  LOAM_TRY(sync_parent_dir(path));
  w->path_ = path;
  return w;
}

Result<LogWriter> LogWriter::reopen_after_failure(const std::string& path, uint64_t durable_bytes,
                                                  uint64_t expected_last_seq) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return io_error(path, "stat");
  if (uint64_t(st.st_size) < durable_bytes) {
    return make_error(ErrorCode::kCorrupt, path,
                      "shorter (" + std::to_string(st.st_size) + " bytes) than what was made durable (" +
                          std::to_string(durable_bytes) + ")");
  }
  if (uint64_t(st.st_size) > durable_bytes) LOAM_TRY(truncate_segment(path, durable_bytes));
  Result<LogWriter> w = open_append(path);
  if (!w.ok()) return w.error();
  if (w->next_seq() != expected_last_seq + 1) {
    return make_error(ErrorCode::kCorrupt, path,
                      "ends at sequence " + std::to_string(w->next_seq() - 1) + ", expected " +
                          std::to_string(expected_last_seq));
  }
  return w;
}

Result<LogWriter> LogWriter::open_append(const std::string& path) {
  Result<SegmentScan> scan = read_segment(path);
  if (!scan.ok()) return scan.error();
  if (scan->tail != TailState::kClean) {
    return make_error(ErrorCode::kCorrupt, path,
                      std::string("segment tail is ") + to_string(scan->tail) + " at byte offset " +
                          std::to_string(scan->damage_offset) + ": recover it before appending");
  }
  LogWriter w;
  w.fd_ = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  if (w.fd_ < 0) return io_error(path, "open");
  w.path_ = path;
  w.header_ = scan->header.header;
  w.header_checksum_ = scan->header.checksum;
  w.next_seq_ = scan->last_seq() + 1;
  w.last_tick_ = scan->last_tick;
  w.file_bytes_ = w.durable_bytes_ = scan->good_bytes;
  return w;
}

LogWriter::LogWriter(LogWriter&& other) noexcept { *this = std::move(other); }

LogWriter& LogWriter::operator=(LogWriter&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    path_ = std::move(other.path_);
    header_ = std::move(other.header_);
    header_checksum_ = other.header_checksum_;
    next_seq_ = other.next_seq_;
    last_tick_ = other.last_tick_;
    file_bytes_ = other.file_bytes_;
    durable_bytes_ = other.durable_bytes_;
    pending_ = std::move(other.pending_);
  }
  return *this;
}

LogWriter::~LogWriter() {
  if (fd_ >= 0) ::close(fd_);
}

Status LogWriter::append(const LogRecord& r) {
  if (fd_ < 0) return make_error(ErrorCode::kIo, path_, "writer is closed");
  if (r.global_seq != next_seq_) {
    return make_error(ErrorCode::kInvalidArgument, "record.global_seq",
                      "expected " + std::to_string(next_seq_) + ", got " + std::to_string(r.global_seq));
  }
  if (r.tick < last_tick_) {
    return make_error(ErrorCode::kInvalidArgument, "record.tick", "ticks must not go backwards");
  }
  LOAM_TRY(append_record(pending_, r));
  ++next_seq_;
  last_tick_ = r.tick;
  return {};
}

Status LogWriter::sync() {
  if (fd_ < 0) return make_error(ErrorCode::kIo, path_, "writer is closed");
  if (!pending_.empty()) {
    Status st = write_all(fd_, pending_.data(), pending_.size(), path_);
    if (!st.ok()) {
      // A partial write (a full disk) may have left whole records of this batch after the
      // durable end: records nobody acknowledged that recovery would replay. Cut them off
      // (this frees space, so it works on a full disk) and refuse further use until reopened.
      fail_back_to_durable();
      return st;
    }
    file_bytes_ += pending_.size();
  }
  if (::fdatasync(fd_) != 0) {
    // After a failed fsync the page cache state is unknown (the "fsyncgate" lesson):
    // never retry on the same descriptor.
    Error e = io_error(path_, "fdatasync");
    fail_back_to_durable();
    return e;
  }
  pending_.clear();
  durable_bytes_ = file_bytes_;
  return {};
}

void LogWriter::fail_back_to_durable() {
  const int saved = errno;
  if (::ftruncate(fd_, off_t(durable_bytes_)) == 0) (void)::fdatasync(fd_);
  ::close(fd_);
  fd_ = -1;
  file_bytes_ = durable_bytes_;
  pending_.clear();
  errno = saved;
}

Result<std::vector<uint8_t>> read_file(const std::string& path, uint64_t max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT) return make_error(ErrorCode::kNotFound, path, "no such file");
    return io_error(path, "open");
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    Error e = io_error(path, "stat");
    ::close(fd);
    return e;
  }
  if (uint64_t(st.st_size) > max_bytes) {
    ::close(fd);
    return make_error(ErrorCode::kOversize, path, "file larger than " + std::to_string(max_bytes) + " bytes");
  }
  std::vector<uint8_t> bytes(size_t(st.st_size));
  size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t r = ::read(fd, bytes.data() + got, bytes.size() - got);
    if (r < 0) {
      if (errno == EINTR) continue;
      Error e = io_error(path, "read");
      ::close(fd);
      return e;
    }
    if (r == 0) break;  // file shrank under us: scan what we have
    got += size_t(r);
  }
  ::close(fd);
  bytes.resize(got);
  return bytes;
}

Result<SegmentScan> read_segment(const std::string& path) {
  Result<std::vector<uint8_t>> bytes = read_file(path);
  if (!bytes.ok()) return bytes.error();
  Result<SegmentScan> scan = scan_segment(*bytes);
  if (!scan.ok()) {
    Error e = scan.error();
    e.message = path + ": " + e.message;
    return e;
  }
  return scan;
}

Result<Recovery> recover_segment(const std::string& path) {
  Result<SegmentScan> scan = read_segment(path);
  if (!scan.ok()) return scan.error();
  Recovery rec;
  if (scan->tail == TailState::kClean) {
    rec.scan = std::move(*scan);
    return rec;
  }
  const Error& damage = *scan->tail_error;
  if (!scan->recoverable) {
    return make_error(ErrorCode::kCorrupt, path,
                      "damage at byte offset " + std::to_string(scan->damage_offset) +
                          " with data after it; not truncating (" + damage.describe() + ")");
  }
  Result<std::vector<uint8_t>> bytes = read_file(path);
  if (!bytes.ok()) return bytes.error();
  rec.removed_bytes = bytes->size() - scan->good_bytes;
  rec.truncated_at = scan->good_bytes;
  rec.damage = damage.describe();
  LOAM_TRY(truncate_segment(path, scan->good_bytes));
  scan->tail = TailState::kClean;
  scan->tail_error.reset();
  scan->damage_offset = 0;
  rec.scan = std::move(*scan);
  return rec;
}

Status truncate_segment(const std::string& path, uint64_t length) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) return io_error(path, "open");
  if (::ftruncate(fd, off_t(length)) != 0 || ::fsync(fd) != 0) {
    Error e = io_error(path, "truncate");
    ::close(fd);
    return e;
  }
  ::close(fd);
  return {};
}

Result<std::vector<SegmentScan>> read_log(const std::vector<std::string>& paths) {
  std::vector<SegmentScan> scans;
  for (const std::string& path : paths) {
    Result<SegmentScan> scan = read_segment(path);
    if (!scan.ok()) return scan.error();
    if (scans.empty()) {
      if (scan->header.header.segment_index != 0 && scan->header.header.base_snapshot_id == 0) {
        return make_error(ErrorCode::kCorrupt, path, "first segment neither segment 0 nor at a snapshot");
      }
    } else if (Status st = check_chain(scans.back(), scan->header.header); !st.ok()) {
      Error e = st.error();
      e.message = path + ": " + e.message;
      return e;
    }
    scans.push_back(std::move(*scan));
  }
  return scans;
}

}  // namespace loam::log
