#include "protocol/file_io.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace loam {

Error file_error(const std::string& path, const std::string& what) {
  return make_error(ErrorCode::kIo, path, what + ": " + std::strerror(errno));
}

Status pread_exact(int fd, uint64_t offset, std::span<uint8_t> out, const std::string& path) {
  size_t done = 0;
  while (done < out.size()) {
    const ssize_t n = ::pread(fd, out.data() + done, out.size() - done, off_t(offset + done));
    if (n < 0) {
      if (errno == EINTR) continue;
      return file_error(path, "read failed");
    }
    if (n == 0) return make_error(ErrorCode::kTruncated, path, "the file ends inside a read");
    done += size_t(n);
  }
  return {};
}

Status write_exact(int fd, std::span<const uint8_t> bytes, const std::string& path) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return file_error(path, "write failed");
    }
    done += size_t(n);
  }
  return {};
}

Status pwrite_exact(int fd, uint64_t offset, std::span<const uint8_t> bytes, const std::string& path) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::pwrite(fd, bytes.data() + done, bytes.size() - done, off_t(offset + done));
    if (n < 0) {
      if (errno == EINTR) continue;
      return file_error(path, "write failed");
    }
    done += size_t(n);
  }
  return {};
}

}  // namespace loam
