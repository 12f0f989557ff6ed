#include "protocol/log/log_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <utility>

namespace loam::log {

namespace {

Error io_error(const std::string& path, const char* what) {
  return make_error(ErrorCode::kIo, path, std::string(what) + ": " + std::strerror(errno));
}

Status write_all(int fd, const uint8_t* p, size_t n, const std::string& path) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return io_error(path, "write");
    }
    p += w;
    n -= size_t(w);
  }
  return {};
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
  LOAM_TRY(write_all(w.fd_, bytes.data(), bytes.size(), path));
  if (::fsync(w.fd_) != 0) return io_error(path, "fsync");
  LOAM_TRY(sync_parent_dir(path));
  w.file_bytes_ = bytes.size();
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
  w.last_tick_ = scan->records.empty() ? 0 : scan->records.back().tick;
  w.file_bytes_ = scan->good_bytes;
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
      // A partial write leaves a torn tail on disk; the file is no longer appendable
      // without recovery, so refuse further use rather than interleave records.
      ::close(fd_);
      fd_ = -1;
      return st;
    }
    file_bytes_ += pending_.size();
    pending_.clear();
  }
  if (::fdatasync(fd_) != 0) {
    // After a failed fsync the page cache state is unknown (the "fsyncgate" lesson):
    // never retry on the same descriptor.
    Error e = io_error(path_, "fdatasync");
    ::close(fd_);
    fd_ = -1;
    return e;
  }
  return {};
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
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) return io_error(path, "open");
  if (::ftruncate(fd, off_t(scan->good_bytes)) != 0 || ::fsync(fd) != 0) {
    Error e = io_error(path, "truncate");
    ::close(fd);
    return e;
  }
  ::close(fd);
  scan->tail = TailState::kClean;
  scan->tail_error.reset();
  scan->damage_offset = 0;
  rec.scan = std::move(*scan);
  return rec;
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
