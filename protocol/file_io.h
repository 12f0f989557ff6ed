// POSIX file reads and writes for the stores in protocol/ (tile packs, snapshots, the log):
// whole-buffer pread/write that retry on EINTR and give an Error naming the file. A short read
// (the file ends first) is kTruncated: the caller's bounds checks said the bytes were there.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "protocol/result.h"

namespace loam {

// kIo with `what` and strerror(errno).
Error file_error(const std::string& path, const std::string& what);
// Reads exactly out.size() bytes at `offset`.
Status pread_exact(int fd, uint64_t offset, std::span<uint8_t> out, const std::string& path);
// Writes every byte at the file position (write) or at `offset` (pwrite).
Status write_exact(int fd, std::span<const uint8_t> bytes, const std::string& path);
Status pwrite_exact(int fd, uint64_t offset, std::span<const uint8_t> bytes, const std::string& path);

}  // namespace loam
