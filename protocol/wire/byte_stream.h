// Byte streams for the one-serialize-function-per-message pattern: WriteStream appends
// little-endian bytes, ReadStream consumes them with a bounds check before every read, and
// MeasureStream counts bytes without writing. A message's serialize(Stream&, T&) is written
// once and runs against all three, so encoder, decoder and size computation cannot drift.
//
// Safe on untrusted input: ReadStream never reads past its span, never allocates more than
// the bytes actually present, and every failure is an Error whose field names what was being
// read (e.g. "subscribe.count") with the byte offset in the message. Caps and range checks run
// in both directions, so an encoder refuses exactly what a decoder would reject.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "protocol/byte_order.h"
#include "protocol/result.h"

namespace loam::wire {

// Errors shared by the three streams (out of line: they build strings).
Error truncated_error(const char* field, size_t need, size_t offset, size_t left);
Error oversize_error(const char* field, uint64_t value, uint64_t cap);
Error bad_enum_error(const char* field, uint64_t value, uint64_t count);
Error not_finite_error(const char* field);

class WriteStream {
 public:
  static constexpr bool kReading = false;
  explicit WriteStream(std::vector<uint8_t>& out) : out_(out) {}

  template <typename T>
  Status bits(T& v, const char*) {
    static_assert(std::is_integral_v<T>);
    const size_t at = out_.size();
    out_.resize(at + sizeof(T));
    store_le<T>(out_.data() + at, v);
    return {};
  }
  Status f64(double& v, const char* field);
  Status boolean(bool& v, const char* field);
  // LEB128: 7 bits a byte, low first, the high bit set on every byte but the last (1..10 bytes).
  Status varint(uint64_t& v, const char* field);
  Status bytes(uint8_t* p, size_t n, const char* field);
  Status string(std::string& s, size_t max_bytes, const char* field);
  Status blob(std::vector<uint8_t>& b, uint32_t max_bytes, const char* field);
  // Writes a u32 element count; the count must already be <= cap.
  Status count(uint32_t& n, uint32_t cap, size_t min_bytes_each, const char* field);

  size_t offset() const { return out_.size(); }

 private:
  std::vector<uint8_t>& out_;
};

class ReadStream {
 public:
  static constexpr bool kReading = true;
  explicit ReadStream(std::span<const uint8_t> in) : in_(in) {}

  template <typename T>
  Status bits(T& v, const char* field) {
    static_assert(std::is_integral_v<T>);
    if (remaining() < sizeof(T)) return truncated_error(field, sizeof(T), pos_, remaining());
    v = load_le<T>(in_.data() + pos_);
    pos_ += sizeof(T);
    return {};
  }
  Status f64(double& v, const char* field);
  Status boolean(bool& v, const char* field);
  // Rejects a varint that runs past the input, past 64 bits, or is not in its shortest form
  // (one encoding per value keeps golden bytes and hashes of messages canonical).
  Status varint(uint64_t& v, const char* field);
  Status bytes(uint8_t* p, size_t n, const char* field);
  Status string(std::string& s, size_t max_bytes, const char* field);
  Status blob(std::vector<uint8_t>& b, uint32_t max_bytes, const char* field);
  // Reads a u32 element count and rejects it when it exceeds cap or when the bytes left
  // cannot hold that many elements of at least min_bytes_each (so a caller may reserve).
  Status count(uint32_t& n, uint32_t cap, size_t min_bytes_each, const char* field);

  size_t offset() const { return pos_; }
  size_t remaining() const { return in_.size() - pos_; }
  // Every message must be consumed exactly: trailing bytes mean the peer and we disagree.
  Status expect_end(const char* field) const;

 private:
  std::span<const uint8_t> in_;
  size_t pos_ = 0;
};

// One field as a message lays it out: the name a decode error gives it, where it starts, its
// width in bytes, and for an integer its value (a count says how many elements follow).
struct FieldSpan {
  std::string field;
  size_t offset = 0, width = 0;
  uint64_t value = 0;
};

// Counts the bytes a message takes without writing them; given a `layout`, it also lists every
// field as it goes (the layout the docs' tables are checked against).
class MeasureStream {
 public:
  static constexpr bool kReading = false;
  explicit MeasureStream(std::vector<FieldSpan>* layout = nullptr) : layout_(layout) {}

  template <typename T>
  Status bits(T& v, const char* field) {
    static_assert(std::is_integral_v<T>);
    record(field, sizeof(T), static_cast<uint64_t>(v));
    return {};
  }
  Status f64(double& v, const char* field);
  Status boolean(bool& v, const char* field);
  Status varint(uint64_t& v, const char* field) {
    size_t n = 0;
    uint64_t x = v;
    do {
      ++n;
      x >>= 7;
    } while (x != 0);
    record(field, n, v);
    return {};
  }
  Status bytes(uint8_t*, size_t n, const char* field) {
    record(field, n, 0);
    return {};
  }
  Status string(std::string& s, size_t max_bytes, const char* field);
  Status blob(std::vector<uint8_t>& b, uint32_t max_bytes, const char* field);
  Status count(uint32_t& n, uint32_t cap, size_t min_bytes_each, const char* field);

  size_t offset() const { return bytes_; }

 private:
  void record(const char* field, size_t n, uint64_t value) {
    if (layout_) layout_->push_back({field, bytes_, n, value});
    bytes_ += n;
  }
  size_t bytes_ = 0;
  std::vector<FieldSpan>* layout_;
};

// Enumerations travel as their underlying integer; values >= count are rejected both ways.
template <typename E, typename S>
Status serialize_enum(S& s, E& v, uint32_t count, const char* field) {
  using U = std::underlying_type_t<E>;
  U raw = static_cast<U>(v);
  LOAM_TRY(s.bits(raw, field));
  if (static_cast<uint64_t>(raw) >= count) return bad_enum_error(field, raw, count);
  if constexpr (S::kReading) v = static_cast<E>(raw);
  return {};
}

// An integer that must lie in [lo, hi] (both ways).
template <typename T, typename S>
Status serialize_range(S& s, T& v, T lo, T hi, const char* field) {
  LOAM_TRY(s.bits(v, field));
  if (v < lo || v > hi) {
    return make_error(ErrorCode::kInvalidArgument, field,
                      std::to_string(v) + " outside " + std::to_string(lo) + ".." + std::to_string(hi));
  }
  return {};
}

// An unsigned integer of any width as a varint; a decoded value that does not fit T (or lies
// outside [lo, hi]) is an error naming the field.
template <typename T, typename S>
Status serialize_uvarint(S& s, T& v, const char* field, T lo = std::numeric_limits<T>::min(),
                         T hi = std::numeric_limits<T>::max()) {
  static_assert(std::is_unsigned_v<T>);
  uint64_t raw = v;
  LOAM_TRY(s.varint(raw, field));
  if (raw < lo || raw > hi) {
    return make_error(ErrorCode::kInvalidArgument, field,
                      std::to_string(raw) + " outside " + std::to_string(lo) + ".." + std::to_string(hi));
  }
  if constexpr (S::kReading) v = static_cast<T>(raw);
  return {};
}

// A signed integer as a zigzag varint (0, -1, 1, -2, ... as 0, 1, 2, 3, ...): small
// magnitudes of either sign take one byte.
template <typename T, typename S>
Status serialize_svarint(S& s, T& v, const char* field) {
  static_assert(std::is_signed_v<T>);
  const int64_t x = v;
  uint64_t raw = (uint64_t(x) << 1) ^ uint64_t(x >> 63);
  LOAM_TRY(s.varint(raw, field));
  const int64_t decoded = int64_t(raw >> 1) ^ -int64_t(raw & 1);
  if (decoded < int64_t(std::numeric_limits<T>::min()) || decoded > int64_t(std::numeric_limits<T>::max())) {
    return make_error(ErrorCode::kInvalidArgument, field, std::to_string(decoded) + " does not fit");
  }
  if constexpr (S::kReading) v = static_cast<T>(decoded);
  return {};
}

}  // namespace loam::wire
