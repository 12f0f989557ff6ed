// The fast mode's escape bits: the raw low bits of large residuals (residual_tokens.h),
// packed LSB first into one byte-aligned section. Writer and reader move eight bytes at a
// time without a branch per value.
//
// Safety on untrusted input: EscapeBitReader reads only inside its buffer. prepare_row
// makes the next row's reads safe (at most 14 bits per sample): near the end of the
// section it continues from a zero-padded copy, so reading past the end yields zeros and
// shows afterwards as overran().
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "protocol/byte_order.h"

namespace loam::codec {

// Every put stores eight bytes and keeps the last partial byte pending, so the buffer needs
// eight bytes of slack after the last byte written.
class EscapeBitWriter {
 public:
  explicit EscapeBitWriter(uint8_t* out) : out_(out) {}
  void put(uint64_t value, uint32_t bits) {  // bits <= 56, value < 2^bits
    acc_ |= value << fill_;
    fill_ += bits;
    store_le<uint64_t>(out_ + pos_, acc_);
    const uint32_t bytes = fill_ >> 3;
    pos_ += bytes;
    acc_ = bytes == 8 ? 0 : acc_ >> (8 * bytes);
    fill_ &= 7;
  }
  // Flushes the pending byte; returns the section's size.
  size_t finish() {
    if (fill_ > 0) out_[pos_++] = uint8_t(acc_);
    fill_ = 0;
    acc_ = 0;
    return pos_;
  }

 private:
  uint8_t* out_;
  size_t pos_ = 0;
  uint64_t acc_ = 0;
  uint32_t fill_ = 0;
};

// `tail` is storage for the padded copy of the section's end (reused across calls).
class EscapeBitReader {
 public:
  EscapeBitReader(std::span<const uint8_t> in, uint32_t width, std::vector<uint8_t>& tail)
      : data_(in.data()),
        size_(in.size()),
        readable_(in.size()),
        row_bytes_(14 * uint64_t(width) / 8 + 9),
        tail_(tail) {}
  // Makes the next row's reads safe; false once the section has overrun.
  bool prepare_row() {
    if (pos_ > 8 * size_) return false;
    if ((pos_ >> 3) + row_bytes_ > readable_) {
      const uint64_t at = pos_ >> 3;
      tail_.assign(size_t(size_ - at + row_bytes_), 0);
      if (size_ > at) std::memcpy(tail_.data(), data_ + at, size_t(size_ - at));
      data_ = tail_.data();
      size_ -= at;
      readable_ = tail_.size();
      pos_ &= 7;
    }
    return true;
  }
  uint32_t get(uint32_t bits) {  // bits <= 14
    const uint64_t w = load_le<uint64_t>(data_ + (pos_ >> 3));
    const uint32_t v = uint32_t(w >> (pos_ & 7)) & ((1u << bits) - 1);
    pos_ += bits;
    return v;
  }
  // For kernels that read a row themselves (within what prepare_row made safe).
  const uint8_t* data() const { return data_; }
  uint64_t& position() { return pos_; }
  bool overran() const { return pos_ > 8 * size_; }
  // Every byte read, and the padding of the last one zero.
  bool exhausted() const {
    if ((pos_ + 7) / 8 != size_) return false;
    return (pos_ & 7) == 0 || (data_[size_ - 1] >> (pos_ & 7)) == 0;
  }

 private:
  const uint8_t* data_;
  uint64_t size_;      // bytes of the section left at data_
  uint64_t readable_;  // bytes readable at data_ (a padded tail is longer than the section)
  uint64_t row_bytes_;
  uint64_t pos_ = 0;
  std::vector<uint8_t>& tail_;
};

}  // namespace loam::codec
