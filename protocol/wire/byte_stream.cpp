#include "protocol/wire/byte_stream.h"

#include <bit>

namespace loam::wire {

Error truncated_error(const char* field, size_t need, size_t offset, size_t left) {
  return make_error(ErrorCode::kTruncated, field,
                    "needs " + std::to_string(need) + " bytes at offset " + std::to_string(offset) +
                        ", only " + std::to_string(left) + " left");
}

Error oversize_error(const char* field, uint64_t value, uint64_t cap) {
  return make_error(ErrorCode::kOversize, field,
                    std::to_string(value) + " exceeds the cap of " + std::to_string(cap));
}

Error bad_enum_error(const char* field, uint64_t value, uint64_t count) {
  return make_error(
      ErrorCode::kBadEnum, field,
      "value " + std::to_string(value) + " is not one of the " + std::to_string(count) + " known values");
}

Error not_finite_error(const char* field) {
  return make_error(ErrorCode::kNotFinite, field, "NaN or infinity where a finite number is required");
}

// --- WriteStream ---

Status WriteStream::f64(double& v, const char* field) {
  if (!std::isfinite(v)) return not_finite_error(field);
  uint64_t raw = std::bit_cast<uint64_t>(v);
  return bits(raw, field);
}

Status WriteStream::boolean(bool& v, const char* field) {
  uint8_t raw = v ? 1 : 0;
  return bits(raw, field);
}

Status WriteStream::varint(uint64_t& v, const char*) {
  uint64_t x = v;
  while (x >= 0x80) {
    out_.push_back(uint8_t(x | 0x80));
    x >>= 7;
  }
  out_.push_back(uint8_t(x));
  return {};
}

Status WriteStream::bytes(uint8_t* p, size_t n, const char*) {
  out_.insert(out_.end(), p, p + n);
  return {};
}

Status WriteStream::string(std::string& s, size_t max_bytes, const char* field) {
  if (s.size() > max_bytes) return oversize_error(field, s.size(), max_bytes);
  uint16_t n = static_cast<uint16_t>(s.size());
  LOAM_TRY(bits(n, field));
  out_.insert(out_.end(), s.begin(), s.end());
  return {};
}

Status WriteStream::blob(std::vector<uint8_t>& b, uint32_t max_bytes, const char* field) {
  if (b.size() > max_bytes) return oversize_error(field, b.size(), max_bytes);
  uint32_t n = static_cast<uint32_t>(b.size());
  LOAM_TRY(bits(n, field));
  out_.insert(out_.end(), b.begin(), b.end());
  return {};
}

Status WriteStream::count(uint32_t& n, uint32_t cap, size_t, const char* field) {
  if (n > cap) return oversize_error(field, n, cap);
  return bits(n, field);
}

// --- ReadStream ---

Status ReadStream::f64(double& v, const char* field) {
  uint64_t raw = 0;
  LOAM_TRY(bits(raw, field));
  v = std::bit_cast<double>(raw);
  if (!std::isfinite(v)) return not_finite_error(field);
  return {};
}

Status ReadStream::boolean(bool& v, const char* field) {
  uint8_t raw = 0;
  LOAM_TRY(bits(raw, field));
  // Only 0 and 1: any other byte means the peer wrote something we do not understand.
  if (raw > 1) return bad_enum_error(field, raw, 2);
  v = raw == 1;
  return {};
}

Status ReadStream::varint(uint64_t& v, const char* field) {
  uint64_t x = 0;
  for (int i = 0; i < 10; ++i) {
    if (remaining() == 0) return truncated_error(field, 1, pos_, 0);
    const uint8_t byte = in_[pos_++];
    if (i == 9 && byte > 1) return make_error(ErrorCode::kCorrupt, field, "varint exceeds 64 bits");
    x |= uint64_t(byte & 0x7F) << (7 * i);
    if ((byte & 0x80) == 0) {
      if (byte == 0 && i > 0)
        return make_error(ErrorCode::kCorrupt, field, "varint not in its shortest form");
      v = x;
      return {};
    }
  }
  return make_error(ErrorCode::kCorrupt, field, "varint longer than 10 bytes");
}

Status ReadStream::bytes(uint8_t* p, size_t n, const char* field) {
  if (remaining() < n) return truncated_error(field, n, pos_, remaining());
  if (n != 0) std::memcpy(p, in_.data() + pos_, n);
  pos_ += n;
  return {};
}

Status ReadStream::string(std::string& s, size_t max_bytes, const char* field) {
  uint16_t n = 0;
  LOAM_TRY(bits(n, field));
  if (n > max_bytes) return oversize_error(field, n, max_bytes);
  // The cap check comes first and the length is checked against the bytes present before
  // any allocation, so a claimed length costs nothing.
  if (remaining() < n) return truncated_error(field, n, pos_, remaining());
  s.assign(reinterpret_cast<const char*>(in_.data() + pos_), n);
  pos_ += n;
  return {};
}

Status ReadStream::blob(std::vector<uint8_t>& b, uint32_t max_bytes, const char* field) {
  uint32_t n = 0;
  LOAM_TRY(bits(n, field));
  if (n > max_bytes) return oversize_error(field, n, max_bytes);
  if (remaining() < n) return truncated_error(field, n, pos_, remaining());
  b.assign(in_.data() + pos_, in_.data() + pos_ + n);
  pos_ += n;
  return {};
}

Status ReadStream::count(uint32_t& n, uint32_t cap, size_t min_bytes_each, const char* field) {
  LOAM_TRY(bits(n, field));
  if (n > cap) return oversize_error(field, n, cap);
  if (min_bytes_each != 0 && uint64_t(n) * min_bytes_each > remaining()) {
    return truncated_error(field, size_t(uint64_t(n) * min_bytes_each), pos_, remaining());
  }
  return {};
}

Status ReadStream::expect_end(const char* field) const {
  if (remaining() == 0) return {};
  return make_error(
      ErrorCode::kCorrupt, field,
      std::to_string(remaining()) + " unexpected trailing bytes at offset " + std::to_string(pos_));
}

// --- MeasureStream ---

Status MeasureStream::f64(double& v, const char* field) {
  if (!std::isfinite(v)) return not_finite_error(field);
  record(field, 8, 0);
  return {};
}

Status MeasureStream::boolean(bool& v, const char* field) {
  record(field, 1, v ? 1 : 0);
  return {};
}

Status MeasureStream::string(std::string& s, size_t max_bytes, const char* field) {
  if (s.size() > max_bytes) return oversize_error(field, s.size(), max_bytes);
  record(field, 2 + s.size(), s.size());
  return {};
}

Status MeasureStream::blob(std::vector<uint8_t>& b, uint32_t max_bytes, const char* field) {
  if (b.size() > max_bytes) return oversize_error(field, b.size(), max_bytes);
  record(field, 4 + b.size(), b.size());
  return {};
}

Status MeasureStream::count(uint32_t& n, uint32_t cap, size_t, const char* field) {
  if (n > cap) return oversize_error(field, n, cap);
  record(field, 4, n);
  return {};
}

}  // namespace loam::wire
